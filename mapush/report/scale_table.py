"""The scalability study (paper §IV-B-3, a figure there): the cylinder with 1-6 robots, and the paper's four
readings of its figure judged here."""

from __future__ import annotations

import numpy as np

from mapush.config import group_file
from mapush.experiments.results import JobResult
from mapush.report import curve_findings
from mapush.report.cells import FALL, PAPER, collect, fall_cell, final_cell, matching
from mapush.report.formats import OTHERWISE, OVER_SEEDS, Finding, Table, counted

SCALE_ROBOTS = list(group_file("experiment", "scale").sweep.agents)
"""The robot counts the scalability study plans (`mapush scale`): rows of its table, finished or not."""


def scale_table(results: list[JobResult], variant: str) -> Table:
    """Scalability: rows the robot counts (the paper's, the study's and any run), columns the hierarchy's S.R. and
    C.T. and the mid level's own S.R. (the paper: a figure)."""
    mine = matching(results, table="scale", variant=variant)
    counts = sorted(set(PAPER["scale"]["robots"]) | set(SCALE_ROBOTS) | {r.num_agents for r in mine})
    rows, missing = [], []
    for n in counts:
        cells = [
            collect(mine, "success_rate", 100.0, num_agents=n, eval="main"),
            collect(mine, "completion_time", 1.0, num_agents=n, eval="main"),
            final_cell(mine, "mid", 100.0, num_agents=n),
            fall_cell(mine, num_agents=n, eval="main"),
        ]
        cells[1].digits = 2
        if not cells[0].values:
            missing.append(f"{counted(n, 'robot')}: no finished job")
        elif not cells[2].values:
            missing.append(f"{counted(n, 'robot')} / mid level: no curve of the mid level alone")
        rows.append(([str(n)], cells))
    findings = []
    marked = {int(labels[0]) for labels, cells in rows if any(c.otherwise for c in cells)}  # an earlier recipe's
    measured = [(c[0].mean, c[0].std, labels[0]) for labels, c in rows if c[0].values]
    if measured:
        top = max(m[0] for m in measured)
        best = [f"{n}{_mark(int(n), marked)} ({mean:.1f} \u00b1 {std:.1f} % S.R.)" for mean, std, n in measured
                if np.isclose(mean, top)]  # fmt: skip
        among = "" if len(measured) == len(rows) else f" of those finished ({', '.join(m[2] for m in measured)})"
        text = f"Best robot count{among} here: {' and '.join(best)}" + (", tied" if len(best) > 1 else "")
        numbers = {f"{m[2]}_robots_sr": float(m[0]) for m in measured}
        findings.append(Finding(text, numbers=numbers, key="best_count"))
    findings += _scale_paper_findings(rows, marked) + _reference_mid_finding(rows)
    lines = {counted(n, "robot"): matching(mine, num_agents=n) for n in counts}
    findings += curve_findings.budget_findings(lines, curve_findings.drawn_stages(mine))
    return Table(
        f"scale_{variant}",
        f"Scalability, cylinder ({variant})",
        ["Robots"],
        ["S.R. (%) \u2191", "C.T. \u2193", "Mid level S.R. (%) \u2191", "Falls (%) \u2193"],
        rows,
        missing,
        f"Whole hierarchy; C.T. normalized by the timeout; {OVER_SEEDS}. Mid level: the "
        "same jobs' mid level alone on its 20 s pushes, at the end of its budget (the last point of its own "
        f"learning curve). Falls: the share of the whole hierarchy's episodes with a robot's fall (eval.json's "
        f"`events`; a record made before events were counted: the share a fall ended, `{FALL}`, under the rules "
        "it was made under, where a fall ended the episode). The paper gives a figure only.",
        findings,
        {"Cylinder": lines},
    )


def _mark(n: int, marked: set[int]) -> str:
    return f" {OTHERWISE}" if n in marked else ""


def _scale_paper_findings(rows: list, marked: set[int]) -> list[Finding]:
    """The paper's four readings of its scalability figure (paper IV-B-3; it gives no numbers), each judged on the
    means over seeds of the whole hierarchy (S.R., and C.T. where the paper says "both metrics") and of the mid
    level alone (S.R.), among the figure's robot counts that finished: one finding per reading and level, about
    the level; one that rests on rows marked as made otherwise (`marked`) says which."""
    figure = PAPER["scale"]["robots"]

    def means(column: int) -> dict[int, float]:
        return {int(labels[0]): c[column].mean for labels, c in rows
                if c[column].values and int(labels[0]) in figure}  # fmt: skip

    def spread(column: int, n: int) -> float:
        return next(c[column].std for labels, c in rows if int(labels[0]) == n)

    ct = means(1)

    def one_struggles(sr: dict, column: int) -> tuple[bool, str] | None:
        if 1 not in sr or len(sr) < 2:
            return None
        others = {n: v for n, v in sr.items() if n != 1}
        low = min(others, key=others.get)
        lowest = f"{counted(low, 'robot')} at {others[low]:.1f} %"
        return sr[1] < others[low], f"1 robot {sr[1]:.1f} %, the lowest other: {lowest}"

    def two_improve(sr: dict, column: int) -> tuple[bool, str] | None:
        if not {1, 2} <= sr.keys():
            return None
        gain, noise = sr[2] - sr[1], max(spread(column, 1), spread(column, 2))
        return gain > noise, f"{gain:+.1f} points, the seeds' spread {noise:.1f}"

    def three_best(sr: dict, column: int) -> tuple[bool, str] | None:
        if 3 not in sr or len(sr) < 2:
            return None
        best = max(sr, key=sr.get)
        holds, detail = best == 3, f"the highest S.R.: {counted(best, 'robot')}"
        if column == 0 and 3 in ct:
            fastest = min(ct, key=ct.get)
            holds, detail = holds and fastest == 3, f"{detail}; the lowest C.T.: {counted(fastest, 'robot')}"
        return holds, detail

    def four_worse(sr: dict, column: int) -> tuple[bool, str] | None:
        if not {3, 4} <= sr.keys():
            return None
        return sr[4] < sr[3], f"{sr[4] - sr[3]:+.1f} points from 3 robots to 4"

    claims = {  # each claim's key: its words, its judge, and the robot counts it reads (None: every one)
        "one_struggles": ("one robot struggles", one_struggles, None),
        "two_improve": ("two robots improve S.R. substantially on one", two_improve, {1, 2}),
        "three_best": ("three robots are best on both metrics", three_best, None),
        "four_worse": ("four robots do slightly worse than three", four_worse, {3, 4}),
    }
    judged = {0: ("whole hierarchy", means(0)), 2: ("mid level alone", means(2))}
    lines = []
    for key, (claim, judge, reads) in claims.items():
        for column, (what, sr) in judged.items():  # one finding per level judged
            verdict = judge(sr, column)
            if verdict is None:
                continue
            text = f"The paper ({', '.join(map(str, figure))} robots): {claim}. Here, {what}: "
            text += f"{'holds' if verdict[0] else 'does not hold'} ({verdict[1]})"
            read = {n: v for n, v in sr.items() if reads is None or n in reads}
            numbers = {f"{n}_robots_sr": v for n, v in read.items()}
            resting = sorted(marked & read.keys())
            if resting:
                text += f" (rows {', '.join(map(str, resting))} marked {OTHERWISE}: an earlier recipe's)"
                numbers["rows_made_otherwise"] = float(len(resting))
            lines.append(Finding(text, bool(verdict[0]), numbers, key=key, about=what))
    return lines


def _reference_mid_finding(rows: list) -> list[Finding]:
    """The mid level at the reference robot count against the original's best stored cylinder mid level."""
    ref = PAPER["scale"]["reference_mid"]
    values = next((cells[2].values for labels, cells in rows if labels[0] == str(ref["robots"])), [])
    if not values:
        return []
    mean, std, bar = float(np.mean(values)), float(np.std(values)), float(ref["success_rate"])
    verdict = "at or above it" if mean >= bar else ("below it, within the seeds' spread" if bar - mean <= std
                                                    else "below it")  # fmt: skip
    text = (
        f"Mid level with {ref['robots']} robots: {mean:.1f} \u00b1 {std:.1f} % S.R. over {len(values)} seeds; "
        f"the original's best stored cylinder mid level reached {bar:g} %: {verdict}"
    )
    holds = True if mean >= bar else (None if bar - mean <= std else False)  # None: within the spread, as the OCB's
    numbers = {"mid_sr": mean, "mid_sr_std": std, "original_sr": bar}
    return [Finding(text, holds, numbers, key="reference_mid", about=counted(int(ref["robots"]), "robot"))]
