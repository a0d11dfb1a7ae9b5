"""What a table cost, measured from the runs behind it: every distinct stage's training time and every job's
evaluation time, in core-hours and in hours of the machine that ran them.

Each table counts a stage once, however many of its jobs use it; tables that share stages (the main table and the
scalability study) each count them, so their costs do not add up. What a table adds after the others, its shared
stages already trained, is given beside (`cost_after`). Training time is the PPO iterations' time as
rsl-rl measures it (`Perf/collection_time` + `Perf/learning_time` in `metrics.mcap`), each iteration once: what an
uninterrupted run costs, without the iterations a cut run repeats after resuming. It is multiplied by the MuJoCo
threads each iteration recorded (else the stage's). Evaluation time is what a job spent after training (its
evaluations and learning curve, `eval_wall_s` in `result.json`) times the job's threads. Jobs that finished
before the pipeline recorded it get it from file times (the evaluated stage's exported policy to the job's
`finished`), but only the first job to evaluate a stage: a later one that reused it left no trace of its own time.
A job that ran again after its experiment changed (`rerun_changed`) counts its earlier result too when only its
evaluations changed; an earlier result of other stages (another recipe) is reported apart: a table's cost is what
its results cost. A job whose result was taken from another table's job that made it (`taken_from`: the
scalability study's 1- and 3-robot jobs are the main table's) evaluated nothing; that job counts the evaluation.
"""

from __future__ import annotations

import datetime
import functools
import os
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from mapush.errors import BadInput
from mapush.experiments import stages
from mapush.experiments.results import JobResult, read_result
from mapush.experiments.stages import run_threads, stage_core_seconds
from mapush.rundir import POLICY_FILE


def measured_cost(
    results: list[JobResult], cores: int | None = None, stage_seconds: Callable[[Path], float] = stage_core_seconds
) -> dict:
    """The cost of the jobs' `results`: training over their distinct stages, evaluation over the jobs, and the
    hours of a `cores`-core machine (default: the one the jobs record, else this one) with every core busy.
    Stages or jobs whose runs cannot be read are left out and counted. `stage_seconds` reads a stage run's
    training core-seconds (a cached reader when one caller measures the same stages again).

    A job that ran again after its experiment changed left its earlier result (`result.superseded.json`). Made
    of the same evaluated stage (only evaluations changed), it counts too: the evaluations the job kept came
    from it. Made of other stages (a recipe changed), it is history, not what the results cost: what it added
    is given apart (`superseded`, `superseded_machine_h`).

    Jobs that ran on a machine of another core count (a lent many-core machine) are counted in core-seconds as
    measured there, which are not this machine's: how many and what they added is said (`other_machines`, cores
    -> jobs; `other_machines_core_h`)."""
    results = [r for r in results if r.stages]  # hand-made results may name none
    pairs = [(r, e) for r in results if (e := _superseded(r))]
    again = [e for r, e in pairs if _evaluated(e) == _evaluated(r)]
    replaced = [e for r, e in pairs if _evaluated(e) != _evaluated(r)]
    cost = _cost_of(results, again, stage_seconds)
    recorded = Counter(int(r.machine_cores) for r in results if r.machine_cores)
    cores = cores or (recorded.most_common(1)[0][0] if recorded else os.cpu_count() or 1)
    seconds = cost.pop("seconds")
    before = _cost_of(results, again + replaced, stage_seconds)["seconds"] - seconds if replaced else 0.0
    elsewhere = [r for r in results if int(r.machine_cores or cores) != cores]
    return {
        **cost,
        "evaluated_again": len(again),
        "cores": cores,
        "machine_h": round(seconds / 3600 / cores, 2),
        "superseded": len(replaced),
        "superseded_machine_h": round(before / 3600 / cores, 2),
        "other_machines": dict(sorted(Counter(int(r.machine_cores) for r in elsewhere).items())),
        "other_machines_core_h": round(_cost_of(elsewhere, [], stage_seconds)["seconds"] / 3600, 2),
    }


def _evaluated(result: JobResult) -> Path:
    """The run dir of the stage a job evaluated (its last)."""
    return result.resolved_stage_runs()[-1]


def _cost_of(results: list[JobResult], earlier: list[JobResult], stage_seconds: Callable[[Path], float]) -> dict:
    """`measured_cost` of the jobs' `results` and of `earlier` results of theirs (counted, but not as jobs), in
    core-hours and in core-seconds (`seconds`)."""
    jobs_now = len(results)
    results = results + earlier
    groups: dict[object, list[Path]] = {}  # a stage and its adopted copies (mapush stages rekey) train once
    for path in {path for r in results for path in r.resolved_stage_runs()}:
        groups.setdefault(_original_stage(path), []).append(path)
    recorded = _recorded_stage_seconds(results)
    training, unreadable, from_records = 0.0, 0, 0
    for copies in groups.values():
        seconds, from_record = _training_seconds(copies, recorded, stage_seconds)
        training += seconds or 0.0
        unreadable += seconds is None
        from_records += from_record
    evaluation, jobs, from_file_times, unknown = 0.0, 0, 0, 0
    first_to_evaluate = _first_to_evaluate(results)
    for k, r in enumerate(results):
        evaluated, resolved = r.stage_runs()[-1], r.resolved_stage_runs()[-1]  # training stops at the evaluated stage
        try:
            if r.eval_wall_s is not None:
                evaluation += float(r.eval_wall_s) * int(r.threads or run_threads(evaluated))
            elif first_to_evaluate.get(resolved) is r:
                finished = datetime.datetime.fromisoformat(r.finished).timestamp()
                spent = max(0.0, finished - os.path.getmtime(evaluated / POLICY_FILE))
                evaluation += spent * run_threads(evaluated)
                from_file_times += 1
            else:
                unknown += 1
                continue
            jobs += k < jobs_now  # an earlier result of a job adds its time, not a job
        except (BadInput, OSError, KeyError, ValueError):
            unknown += k < jobs_now
    return {
        "stages": len(groups) - unreadable,
        "unreadable_stages": unreadable,
        "stages_from_records": from_records,
        "jobs": jobs,
        "jobs_without_evaluation_time": unknown,
        "training_core_h": round(training / 3600, 2),
        "evaluation_core_h": round(evaluation / 3600, 2),
        "evaluation_jobs_from_file_times": from_file_times,
        "jobs_taken": sum(1 for r in results[:jobs_now] if r.taken_from),
        "seconds": training + evaluation,
    }


def _training_seconds(
    copies: list[Path], recorded: dict[Path, float], stage_seconds: Callable[[Path], float]
) -> tuple[float | None, bool]:
    """One stage's training core-seconds, from its run dir and any adopted copies (a copy holds its original's
    iterations and, if it resumed, more: the largest is the stage's cost), and whether they came from the jobs'
    records: those where every copy has one (reading a run's log takes seconds), else the runs' logs, else the
    records there are (a run gone, as an archived job's, or a slim copy without its logs). None: no way to know."""
    known = [recorded[path] for path in copies if path in recorded]
    if len(known) == len(copies):
        return max(known), True
    try:
        return max(stage_seconds(path) for path in copies), False
    except (BadInput, OSError):
        return (max(known), True) if known else (None, False)


def cost_by(results: list[JobResult], key: str, cores: int) -> dict[str, float]:
    """Hours of the `cores`-core machine that each group of `results` (by `r[key]`, in first-seen order) added to
    the whole: the cost of the groups so far less that of the groups before, so a stage that two groups share
    counts in the first and the parts add up to the whole."""
    stage_seconds = functools.cache(stage_core_seconds)  # each prefix re-measures the stages before it
    parts: dict[str, float] = {}
    so_far: list[dict] = []
    before = 0.0
    for group in dict.fromkeys(getattr(r, key) for r in results):
        so_far += [r for r in results if getattr(r, key) == group]
        total = measured_cost(so_far, cores, stage_seconds)["machine_h"]
        parts[str(group)] = round(total - before, 2)
        before = total
    return parts


def cost_after(results: list[JobResult], others: list[JobResult], cores: int) -> dict | None:
    """What the jobs' `results` add to the jobs of other tables (`others`), in hours of the `cores`-core machine:
    the table's cost when it runs after them, the stages it shares with them already trained (the scalability
    study after the main table). None when they share no stage."""
    mine = set().union(*(r.resolved_stage_runs() for r in results))
    shared_by: dict[str, set[Path]] = {}  # table -> the stages of `results` it shares
    for r in others:
        if common := mine.intersection(r.resolved_stage_runs()):
            shared_by.setdefault(str(r.table), set()).update(common)
    if not shared_by:
        return None
    shared = set().union(*shared_by.values())
    stage_seconds = functools.cache(stage_core_seconds)
    before = measured_cost(others, cores, stage_seconds)["machine_h"]
    after = measured_cost(others + results, cores, stage_seconds)["machine_h"]
    return {"tables": sorted(shared_by), "shared_stages": len(shared), "machine_h": round(after - before, 2)}


def _recorded_stage_seconds(results: list[JobResult]) -> dict[Path, float]:
    """Stage run -> the core-seconds a job recorded for it when it finished (`stage_core_s`): the cost of a stage
    whose run is gone, as for the archived results of `mapush archive`."""
    recorded: dict[Path, float] = {}
    for r in results:
        seconds = r.stage_core_s or {}
        for name, path in zip(r.stages, r.resolved_stage_runs(), strict=True):
            if name in seconds:
                recorded[path] = max(recorded.get(path, 0.0), float(seconds[name]))
    return recorded


def _original_stage(run_dir: Path) -> object:
    """What a stage run was trained as: the identity at the end of its store dir's `adopted_from` chain (with the
    store), or the run dir itself outside a store."""
    root = stages.store_root(run_dir)
    if root is None:
        return run_dir
    return root, stages.stands_for(root, stages.identity_of(run_dir))[-1]


def _superseded(result: JobResult) -> JobResult | None:
    """The earlier result a job replaced when it ran again (`supersedes`), with its job dir; None without one."""
    if not result.supersedes or not result.job_dir:
        return None
    path = Path(result.job_dir) / result.supersedes
    if not path.is_file():
        return None
    found = path.stat()
    return _read_superseded(str(path), found.st_size, found.st_mtime_ns)


@functools.lru_cache(maxsize=1024)
def _read_superseded(path: str, _size: int, _mtime_ns: int) -> JobResult:
    """An earlier result, read once while its file stays as it is: the cost lines ask for each many times. Read
    only, never changed."""
    return read_result(Path(path))


def _first_to_evaluate(results: list[JobResult]) -> dict[Path, JobResult]:
    """Per evaluated stage, the earliest-finished job that evaluates it (the one that may have trained it); a job
    taken from another (`taken_from`) evaluated nothing."""
    first: dict[Path, JobResult] = {}
    for r in sorted((r for r in results if not r.taken_from), key=lambda r: r.finished):
        first.setdefault(r.resolved_stage_runs()[-1], r)
    return first


def cost_line(cost: dict) -> str:
    """The cost as one sentence under a table ("" when there is nothing to say)."""
    if not cost.get("jobs") and not cost.get("unreadable_stages"):
        return ""
    notes = []
    if cost["evaluation_jobs_from_file_times"]:
        notes.append(f"{cost['evaluation_jobs_from_file_times']} of the jobs' evaluation times from file times")
    if cost["jobs_without_evaluation_time"]:
        notes.append(f"{cost['jobs_without_evaluation_time']} jobs without a recorded evaluation time left out")
    if cost.get("jobs_taken"):
        notes.append(f"{cost['jobs_taken']} jobs' results taken from other tables' jobs, whose evaluation they count")
    if cost.get("evaluated_again"):
        notes.append(f"{cost['evaluated_again']} jobs evaluated again after their experiment changed: both counted")
    if cost.get("superseded"):
        notes.append(f"not counted: {cost['superseded_machine_h']:.1f} hours more on {cost['superseded']} earlier "
                     "results that jobs replaced when their experiment changed")  # fmt: skip
    if cost.get("other_machines"):
        where = " and ".join(f"{jobs} on a {cores}-core machine" for cores, jobs in cost["other_machines"].items())
        notes.append(f"jobs run elsewhere: {where}; their {cost['other_machines_core_h']:.1f} core-hours are counted "
                     "as measured there, on other cores than this machine's")  # fmt: skip
    if cost.get("stages_from_records"):
        notes.append(
            f"{cost['stages_from_records']} stages' training time as their jobs recorded it when they finished"
        )
    if cost["unreadable_stages"]:
        notes.append(f"{cost['unreadable_stages']} stage runs not found or unreadable, left out")
    extra = f" ({'; '.join(notes)})" if notes else ""
    parts = cost.get("by_method") or {}
    by_method = ", ".join(f"{label} {hours:.1f}" for label, hours in parts.items())
    after = cost.get("after")
    shared = (
        f"; run after the {' and '.join(after['tables'])} table's jobs ({after['shared_stages']} stages shared), "
        f"it adds {after['machine_h']:.1f} hours"
        if after
        else ""
    )
    return (
        f"Cost, measured from the runs (each stage once, each of its iterations once): training "
        f"{cost['training_core_h']:.1f} core-hours over {cost['stages']} distinct stages, evaluation "
        f"{cost['evaluation_core_h']:.1f} core-hours over {cost['jobs']} jobs{extra}: {cost['machine_h']:.1f} "
        f"hours of a {cost['cores']}-core machine with every core busy"
        + (f"; by method, in hours of that machine: {by_method}" if len(parts) > 1 else "")
        + shared
    )
