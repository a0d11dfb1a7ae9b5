"""What every table is made of: the paper's numbers and the cells collected from jobs' `result.json` records."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from mapush.config import group_file
from mapush.experiments.results import JobResult
from mapush.report import curve_findings
from mapush.report.formats import Cell, Finding, counted, significant

PAPER = yaml.safe_load((Path(__file__).with_name("paper.yaml")).read_text())
"""The paper's numbers (`paper.yaml`), which the tables print in parentheses beside ours; the main table's
`labels` are its methods' own (`label` in `conf/method/`)."""
PAPER["main"]["labels"] = {m: str(group_file("method", m).label) for m in PAPER["main"]["methods"]}


def setup_of(results: list[JobResult]) -> str:
    """The rules and low level the `results`' stages were trained under, with how many jobs each: "Trained under
    rules=original on lowlevel=tracker (12 jobs)"; results made before jobs recorded them are counted apart, as
    rules=strict."""
    counts: dict[str, int] = {}
    for r in results:
        if r.rules:
            key = f"rules={r.rules} on lowlevel={r.lowlevel}"
            counts[key] = counts.get(key, 0) + 1
    parts = [f"{key} ({counted(n, 'job')})" for key, n in sorted(counts.items(), key=lambda kv: -kv[1])]
    before = sum(not r.rules for r in results)
    if before:
        parts.append(
            f"rules=strict ({counted(before, 'job')} made before jobs recorded their rules and low level on "
            "2026-12-06, under mapush's own rules, named so since)"
        )
    return f"Trained under {'; '.join(parts)}" if parts else ""


def matching(results: list[JobResult], **match) -> list[JobResult]:
    """The results whose fields have the values `match` gives (e.g. `method="ours", task="cuboid"`)."""
    return [r for r in results if all(getattr(r, k) == v for k, v in match.items())]


def collect(results: list[JobResult], metric: str, scale: float, **match) -> Cell:
    """The cell of the results that match (key: value or eval name), for one metric of one evaluation."""
    eval_name = match.pop("eval")
    return _gathered(
        matching(results, **match),
        lambda r: r.evals[eval_name].metric(metric) if eval_name in r.evals else None,  # a record may lack it
        lambda r, change: change.concerns(r, eval_name),
        scale,
    )


def event_cell(results: list[JobResult], event: str, **match) -> Cell:
    """The cell of the % of an evaluation's episodes in which `event` happened at least once (`falls`,
    `robot_contacts`, `object_tilts`: eval.json's `events`, whatever ended the episodes), from the results whose
    records count events (evaluations before they were counted have none)."""
    eval_name = match.pop("eval")

    def share(r: JobResult) -> float | None:
        evaluation = r.evals.get(eval_name)
        found = evaluation and evaluation.events and evaluation.events.get(event)
        return found.episode_share if found else None

    return _gathered(matching(results, **match), share, lambda r, change: change.concerns(r, eval_name), 100.0)


FALL = "robot_tilt"
"""The exception a robot's fall ends an episode with (`exceptions` in `conf/level/`)."""


def fall_cell(results: list[JobResult], **match) -> Cell:
    """The cell of the % of an evaluation's episodes with a robot's fall: its `events` count, or, in a record made
    before events were counted (under rules where a fall ends the episode), the share its `robot_tilt` ended."""
    eval_name = match.pop("eval")

    def share(r: JobResult) -> float | None:
        evaluation = r.evals.get(eval_name)
        if evaluation is None:
            return None
        if evaluation.events is not None:
            return evaluation.events["falls"].episode_share
        if evaluation.also.get("rules") == "original":  # a fall ends no episode there: its exceptions tell nothing
            return None
        return None if evaluation.exceptions is None else evaluation.exceptions.get(FALL, 0.0)

    return _gathered(matching(results, **match), share, lambda r, change: change.concerns(r, eval_name), 100.0)


def final_cell(results: list[JobResult], stage: str, scale: float, **match) -> Cell:
    """The cell of the last point of each matching result's own curve of `stage` (`stage_curves`: e.g. the mid
    level alone under a high level, at the end of its budget), for its success rate."""

    def last(r: JobResult) -> float | None:
        curve = (r.stage_curves or {}).get(stage)
        return curve.points[-1]["success_rate"] if curve and curve.points else None

    return _gathered(matching(results, **match), last, lambda r, change: change.concerns_stage(r, stage), scale)


def _gathered(results: list[JobResult], value, concerned, scale: float) -> Cell:
    """A cell of `value(r)` x `scale` for each result that has one (None: it has none), with its job dir, counting
    the results made otherwise than planned now whose change is `concerned(r, change)` with that value."""
    cell = Cell()
    for r in results:
        found = value(r)
        if found is None:
            continue
        cell.values.append(significant(scale * float(found)))
        cell.sources.append(r.job_dir)
        change = r.made_otherwise
        cell.otherwise += change is not None and concerned(r, change)
    return cell


def reach_cell(results: list[JobResult]) -> Cell:
    """Env-steps (M) to the curve's `reach` success rate, over the seeds of `results`."""
    values, sources, unreached = curve_findings.reach_values(results)
    return Cell(values, sources, digits=2, unreached=unreached)


def exception_shares(results: list[JobResult], eval_names: list[str]) -> tuple[dict[str, float], int]:
    """Which exceptions ended the episodes of the evaluations `eval_names` of `results`: % of the episodes by kind,
    largest first (mean over the records that name their exceptions, a kind one record lacks counting 0 there;
    kinds that ended none left out), and how many records that is."""
    return record_shares([(r, name) for r in results for name in eval_names])


def record_shares(records: list[tuple[JobResult, str]]) -> tuple[dict[str, float], int]:
    """`exception_shares` of the given (result, evaluation name) pairs."""
    evaluations = [r.evals.get(name) for r, name in records]
    shares = [e.exceptions for e in evaluations if e is not None and e.exceptions is not None]
    if not shares:
        return {}, 0
    kinds = sorted({kind for s in shares for kind in s})
    mean = {kind: 100.0 * float(np.mean([s.get(kind, 0.0) for s in shares])) for kind in kinds}
    return {kind: share for kind, share in sorted(mean.items(), key=lambda kv: -kv[1]) if share > 0}, len(shares)


EVENTS = {"falls": "a fall", "robot_contacts": "robots touching", "object_tilts": "the object tilted"}
"""What an evaluation counts per episode whatever ends it (eval.json's `events`), and how a finding names each."""


def event_shares(results: list[JobResult], eval_name: str) -> tuple[dict[str, float], int]:
    """% of the evaluation's episodes in which each event of `EVENTS` happened (mean over the records that count
    events; those before them count none), and how many records that is."""
    evaluations = [r.evals.get(eval_name) for r in results]
    counts = [e.events for e in evaluations if e is not None and e.events is not None]
    if not counts:
        return {}, 0
    kinds = [kind for kind in EVENTS if all(kind in c for c in counts)]
    return {kind: 100.0 * float(np.mean([c[kind].episode_share for c in counts])) for kind in kinds}, len(counts)


def events_finding(arms: dict[str, list[JobResult]], eval_name: str, what: str) -> list[Finding]:
    """One line: in what share of each arm's episodes of an evaluation a robot fell, robots touched or the object
    tilted, whatever ended them (under the original's rules a fall ends none); none where no record counts events."""
    parts, numbers = [], {}
    for label, results in arms.items():
        shares, seeds = event_shares(results, eval_name)
        if seeds:
            parts.append(f"{label} " + ", ".join(f"{EVENTS[k]} {v:.0f} %" for k, v in shares.items()))
            numbers.update({f"{label} {kind}": share for kind, share in shares.items()})
    if not parts:
        return []
    text = f"{what}: episodes with (mean over seeds): {'; '.join(parts)}"
    return [Finding(text, numbers=numbers, key="events", about=what)]


def success_time(success_rate: float, completion_time: float) -> float | None:
    """The mean completion time of the successful episodes alone, as a fraction of the timeout, from a success rate
    (0-1) and a C.T. that counts every failure as the timeout: C.T. = (1 - S.R.) + S.R. x t. None with no success.
    It puts the paper's C.T. and ours on one footing: how fast the pushes that succeed are."""
    if success_rate <= 0:
        return None
    return (completion_time - (1.0 - success_rate)) / success_rate


FALL_RUNG = "fall_ends"
"""The evaluation that repeats a job's `main` one under the original's rules but ends an episode at a robot's fall
(the ladder's rung 2, conf/ladder/rungs.yaml)."""


def fall_split(results: list[JobResult], eval_name: str = "main") -> tuple[dict[str, float], int]:
    """Where a fall takes a hierarchy's successes: the share (%) of episodes with a robot's fall, and the S.R. (%) of
    the episodes without one and of those with one (means over the seeds that have them), and how many seeds.

    Read from the evaluation `eval_name`, where a fall ends no episode, and its `FALL_RUNG` twin: the same seeds,
    so the same episodes up to a first fall. There an episode succeeds only if no robot fell before it did, so its
    S.R. is the share of episodes that succeed without a fall. A seed whose two evaluations count another share of
    episodes with a fall did not run the same episodes and is left out."""
    shares, free, fell = [], [], []
    for r in results:
        whole, ended = r.evals.get(eval_name), r.evals.get(FALL_RUNG)
        if not (whole and ended and whole.events and ended.events and "falls" in whole.events):
            continue
        share = whole.events["falls"].episode_share
        if "falls" not in ended.events or not np.isclose(share, ended.events["falls"].episode_share, atol=1e-6):
            continue
        shares.append(100.0 * share)
        if share < 1.0:
            free.append(100.0 * ended.success_rate / (1.0 - share))
        if share > 0.0:
            fell.append(100.0 * (whole.success_rate - ended.success_rate) / share)
    numbers = {"fall_share": float(np.mean(shares))} if shares else {}
    numbers |= {"sr_without_fall": float(np.mean(free))} if free else {}
    numbers |= {"sr_with_fall": float(np.mean(fell))} if fell else {}
    return numbers, len(shares)


def fall_split_finding(arms: dict[str, list[JobResult]], what: str, paper_sr: float | None = None) -> list[Finding]:
    """One line: for each arm whose jobs have both evaluations (`fall_split`), the S.R. of its episodes without a
    robot's fall and with one, beside the paper's S.R. where it has one: how much of a shortfall the falls make."""
    parts, numbers = [], {}
    for label, results in arms.items():
        split, seeds = fall_split(results)
        if not seeds:
            continue
        free, fell = split.get("sr_without_fall"), split.get("sr_with_fall")
        words = [f"{label}: a fall in {split['fall_share']:.0f} % of episodes"]
        words += [f"without one {free:.1f} % succeed"] if free is not None else []
        words += [f"with one {fell:.1f} %"] if fell is not None else []
        parts.append(", ".join(words) + f" ({counted(seeds, 'seed')})")
        numbers |= {f"{label} {k}": v for k, v in split.items()}
    if not parts:
        return []
    paper = f"; the paper: {paper_sr:.1f} % in all" if paper_sr is not None else ""
    text = f"{what}: S.R. without and with a robot's fall (main against {FALL_RUNG}): {'; '.join(parts)}{paper}"
    return [Finding(text, numbers=numbers, key="fall_split", about=what)]


def named_shares(shares: dict[str, float]) -> str:
    """`exception_shares`' kinds as text: "robot_tilt 20 %, robot_collision 2 %"."""
    return ", ".join(f"{kind} {share:.0f} %" for kind, share in shares.items())
