"""The ladder: which rule decides each of the paper's findings.

The policies the main table and the scalability study trained under the original's rules, evaluated on every rung
of `ladder.yaml` (evaluations the jobs make: `conf/ladder/rungs.yaml`), from the original's setup toward mapush's.
Rows: Ours and SA on each object, the cylinder with 1-4 robots. Under the table, each finding of the paper with
the first rung at which it stops holding (means over seeds, as the main table compares them).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import yaml

from mapush.experiments.results import JobResult
from mapush.report.cells import PAPER, collect, event_cell, matching
from mapush.report.formats import OVER_SEEDS, Cell, Finding, Table, counted

LADDER = yaml.safe_load(Path(__file__).with_name("ladder.yaml").read_text())
"""The ladder's declaration: its rungs in order, its rows and the bars of the paper's claims (`ladder.yaml`)."""
OCB_RUNGS = {"main": "t20", "strict": "t20_strict", "old_tracker": "t20_old_tracker"}
"""The OCB ablation's evaluations (its 20 s pushes) that stand on a rung of the ladder; the other rungs change
nothing a mid-level push sees (the high level's friction, the hierarchy's ending, the legs) and are not judged."""


@dataclass(frozen=True)
class Rung:
    """One column: the jobs' evaluation it reads, its label and what it changes."""

    eval: str
    label: str
    what: str


RUNGS = [Rung(**r) for r in LADDER["rungs"]]


def ladder_table(results: list[JobResult], variant: str) -> Table:
    """The ladder of `variant`: S.R. (%) per row and rung, with the paper's findings judged rung by rung."""
    main = [r for r in matching(results, table="main", variant=variant) if r.method in LADDER["methods"]]
    scale = [r for r in matching(results, table="scale", variant=variant) if r.num_agents in LADDER["robots"]]
    ocb = matching(results, table="ocb_ablation", variant=variant)
    labels = PAPER["main"]["task_labels"]
    rows, falls, missing = [], [], []
    for task in LADDER["objects"]:
        for method in LADDER["methods"]:
            label = [labels[task], PAPER["main"]["labels"][method]]
            picked = {"method": method, "task": task}
            rows.append((label, [collect(main, "success_rate", 100.0, **picked, eval=r.eval) for r in RUNGS]))
            falls.append((label, [event_cell(main, "falls", **picked, eval=r.eval) for r in RUNGS]))
    for n in LADDER["robots"]:
        label = [labels["cylinder"], counted(n, "robot")]
        rows.append((label, [collect(scale, "success_rate", 100.0, num_agents=n, eval=r.eval) for r in RUNGS]))
        falls.append((label, [event_cell(scale, "falls", num_agents=n, eval=r.eval) for r in RUNGS]))
    for labels_of_row, cells in rows:
        empty = [r.label for r, c in zip(RUNGS, cells, strict=True) if not c.values]
        if empty:
            missing.append(f"{' / '.join(labels_of_row)}: no finished evaluation at {', '.join(empty)}")
    findings = [*judge_claims(rows, ocb), *_fall_lines(falls)]
    rungs_note = "; ".join(f"{r.label}: {r.what}" for r in RUNGS)
    return Table(
        f"ladder_{variant}",
        f"The ladder: the paper's findings from the original's rules to mapush's ({variant})",
        ["Object", "Team"],
        [r.label for r in RUNGS],
        rows,
        missing,
        f"S.R. (%) of the whole hierarchy, {OVER_SEEDS}; policies trained under the original's rules (the main "
        f"table's Ours and SA, the scalability study's robot counts) on the tracker, evaluated on each rung, nothing "
        f"trained for a rung. Rungs: {rungs_note}.",
        findings,
        also_behind=[*main, *scale, *ocb],
    )


Verdict = tuple[bool, str] | None
"""A claim on one rung: (holds, the numbers it rests on), or None where its cells are not all measured."""


def _means(rows: list, rung: int) -> dict[tuple[str, str], float]:
    return {tuple(labels): cells[rung].mean for labels, cells in rows if cells[rung].values}


def _std(rows: list, rung: int, key: tuple[str, str]) -> float:
    return next(cells[rung].std for labels, cells in rows if tuple(labels) == key)


def judge_claims(rows: list, ocb: list[JobResult]) -> list[Finding]:
    """Each claim of the paper on every rung: where it first stops holding, or that it holds on every rung
    measured, and the rungs not measured."""
    sa, ours = PAPER["main"]["labels"]["sa"], PAPER["main"]["labels"]["ours"]
    objects = [PAPER["main"]["task_labels"][t] for t in LADDER["objects"]]
    cylinder = PAPER["main"]["task_labels"]["cylinder"]
    robots = {n: (cylinder, counted(n, "robot")) for n in LADDER["robots"]}

    def every_object(method: str, test: Callable[[float], bool], bar: str) -> Callable[[int], Verdict]:
        def judge(rung: int) -> Verdict:
            means = _means(rows, rung)
            found = {o: means.get((o, method)) for o in objects}
            if None in found.values():
                return None
            return all(map(test, found.values())), ", ".join(f"{o} {v:.1f} %" for o, v in found.items()) + bar

        return judge

    def team_above_one(rung: int) -> Verdict:
        means = _means(rows, rung)
        pairs = {o: (means.get((o, ours)), means.get((o, sa))) for o in objects}
        if any(None in p for p in pairs.values()):
            return None
        return all(a > b for a, b in pairs.values()), ", ".join(f"{o} {a:.1f} vs {b:.1f} %" for o, (a, b) in
                                                                 pairs.items())  # fmt: skip

    def two_above_one(rung: int) -> Verdict:
        means = _means(rows, rung)
        if robots[1] not in means or robots[2] not in means:
            return None
        gain = means[robots[2]] - means[robots[1]]
        spread = max(_std(rows, rung, robots[1]), _std(rows, rung, robots[2]))
        return gain > spread, f"{gain:+.1f} points from 1 robot to 2, the seeds' spread {spread:.1f}"

    def three_best(rung: int) -> Verdict:
        means = _means(rows, rung)
        found = {n: means.get(key) for n, key in robots.items()}
        if None in found.values():
            return None
        best = max(found, key=found.get)
        return best == 3, f"the highest: {counted(best, 'robot')} ({found[best]:.1f} %)"

    def four_below_three(rung: int) -> Verdict:
        means = _means(rows, rung)
        if robots[3] not in means or robots[4] not in means:
            return None
        return means[robots[4]] < means[robots[3]], f"{means[robots[4]] - means[robots[3]]:+.1f} points from 3 to 4"

    def ocb_gain(rung: int) -> Verdict | str:
        name = OCB_RUNGS.get(RUNGS[rung].eval)
        if name is None:
            return "not applicable"
        with_ocb = collect(ocb, "success_rate", 100.0, method="ours", eval=name)
        without = collect(ocb, "success_rate", 100.0, method="ours_no_ocb", eval=name)
        if not with_ocb.values or not without.values:
            return None
        return with_ocb.mean > without.mean, f"{with_ocb.mean:.1f} vs {without.mean:.1f} % at 20 s"

    bars = LADDER["claims"]
    claims = {  # each claim's key: its words and its judge
        "sa_below": (f"{sa} under {bars['sa_below']:g} % S.R. on every object", every_object(
            sa, lambda v: v < bars["sa_below"], f" (bar {bars['sa_below']:g} %)")),
        "ours_at_least": (f"{ours} at least {bars['ours_at_least']:g} % S.R. on every object", every_object(
            ours, lambda v: v >= bars["ours_at_least"], f" (bar {bars['ours_at_least']:g} %)")),
        "team_above_one": (f"{ours} (a team) above {sa} (one robot) on every object", team_above_one),
        "two_above_one": ("two robots well above one on the cylinder (by more than the seeds' spread)",
                          two_above_one),
        "three_best": ("three robots best on the cylinder (of 1-4)", three_best),
        "four_below_three": ("four robots below three on the cylinder", four_below_three),
        "ocb_gain": ("OCB's gain: the mid level with OCB above it without (20 s pushes)", ocb_gain),
    }  # fmt: skip
    return [_ladder_finding(key, claim, judge) for key, (claim, judge) in claims.items()]


def _ladder_finding(key: str, claim: str, judge: Callable[[int], Verdict | str]) -> Finding:
    """One claim over the rungs: the first rung where it stops holding (or that it holds on every rung judged)."""
    verdicts = [judge(k) for k in range(len(RUNGS))]
    judged = [(k, v) for k, v in enumerate(verdicts) if isinstance(v, tuple)]
    unmeasured = [RUNGS[k].label for k, v in enumerate(verdicts) if v is None]
    failing = next(((k, v) for k, v in judged if not v[0]), None)
    if not judged:
        text, holds, numbers = f"The paper: {claim}. Not measured on any rung", None, {}
    elif failing is None:
        text = f"The paper: {claim}. Holds on every rung measured (at {RUNGS[judged[-1][0]].label}: {judged[-1][1][1]})"
        holds, numbers = True, {}
    else:
        k, (_, detail) = failing
        text = f"The paper: {claim}. First stops holding at {RUNGS[k].label} ({detail})"
        before = [RUNGS[j].label for j, v in judged if j < k]
        text += f"; held at {', '.join(before)}" if before else "; held at no rung before it"
        holds, numbers = False, {"first_failing_rung": float(k)}
    if unmeasured:
        text += f"; not measured at {', '.join(unmeasured)}"
    return Finding(text, holds, {**numbers, "unmeasured_rungs": float(len(unmeasured))}, key=key)


def _fall_lines(falls: list[tuple[list[str], list[Cell]]]) -> list[Finding]:
    """The share of episodes with a robot's fall, per row over the rungs (eval.json's `events`)."""
    lines = []
    for labels, cells in falls:
        if any(c.values for c in cells):
            shares = ", ".join(f"{r.label} {c.text()}" for r, c in zip(RUNGS, cells, strict=True))
            row, numbers = " / ".join(labels), {r.label: c.mean for r, c in zip(RUNGS, cells, strict=True) if c.values}
            lines.append(Finding(f"Episodes with a fall (%), {row}: {shares}", numbers=numbers, key="falls", about=row))
    return lines
