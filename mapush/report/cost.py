"""What a table cost, measured from the runs behind it: every distinct stage's training time and every job's
evaluation time, in core-hours and in hours of this machine.

A stage that several jobs or experiments share is counted once. Training time is the PPO iterations' time as
rsl-rl measures it (`Perf/collection_time` + `Perf/learning_time` in `metrics.mcap`; a resumed run's repeated
iterations once), times the stage's MuJoCo threads. Evaluation time is what a job spent after training (its
evaluations and learning curve, `eval_wall_s` in `result.json`); jobs that finished before the pipeline recorded
it get it from file times (the evaluated stage's exported policy to the job's `finished`).
"""

from __future__ import annotations

import datetime
import os
from pathlib import Path

from mapush.config import load_run_config
from mapush.logging.mcap_files import training_scalars
from mapush.rl.runner import POLICY_FILE

ITERATION_TIMES = ("Perf/collection_time", "Perf/learning_time")
"""The training scalars whose sum is one PPO iteration's wall time."""


def stage_core_seconds(run_dir: Path) -> float:
    """Core-seconds of one stage's training: its iterations' wall time times its MuJoCo threads."""
    scalars = training_scalars(run_dir, prefix="Perf/")
    seconds = sum(sum(scalars.get(tag, {}).values()) for tag in ITERATION_TIMES)
    return seconds * _threads(run_dir)


def job_evaluation(result: dict) -> tuple[float, bool]:
    """(core-seconds a job spent evaluating, whether the job recorded them itself rather than file times)."""
    evaluated = _evaluated_stage(result)
    threads = _threads(evaluated)
    if "eval_wall_s" in result:
        return float(result["eval_wall_s"]) * threads, True
    finished = datetime.datetime.fromisoformat(result["finished"]).timestamp()
    return max(0.0, finished - os.path.getmtime(evaluated / POLICY_FILE)) * threads, False


def _evaluated_stage(result: dict) -> Path:
    return Path(list(result["stages"].values())[-1])  # training stops at the evaluated stage


def _threads(run_dir: Path) -> int:
    """The cores a run's physics used: `sim.nthread`, where 0 means every core of the machine."""
    return int(load_run_config(run_dir).sim.nthread) or os.cpu_count() or 1


def measured_cost(results: list[dict], cores: int | None = None) -> dict:
    """The cost of the jobs' `results`: training over their distinct stages, evaluation over the jobs, and the
    hours of a `cores`-core machine (default: this one's) that both take with every core busy."""
    cores = cores or os.cpu_count() or 1
    results = [r for r in results if r.get("stages")]  # hand-made results may name none
    stages = {Path(path).resolve() for r in results for path in r["stages"].values()}
    present = [path for path in stages if path.is_dir()]  # a results tree copied without its stage runs: not all
    training = sum(stage_core_seconds(path) for path in present)
    evaluations = [job_evaluation(r) for r in results if _evaluated_stage(r).is_dir()]
    evaluation = sum(seconds for seconds, _ in evaluations)
    return {
        "stages": len(present),
        "jobs": len(evaluations),
        "missing_runs": len(stages) - len(present),
        "training_core_h": round(training / 3600, 2),
        "evaluation_core_h": round(evaluation / 3600, 2),
        "evaluation_jobs_from_file_times": sum(1 for _, recorded in evaluations if not recorded),
        "cores": cores,
        "machine_h": round((training + evaluation) / 3600 / cores, 2),
    }


def cost_line(cost: dict) -> str:
    """The cost as one sentence under a table."""
    if not cost.get("jobs"):
        return ""
    estimated = cost["evaluation_jobs_from_file_times"]
    note = f", {estimated} of them from file times" if estimated else ""
    if cost["missing_runs"]:
        note += f" ({cost['missing_runs']} stage run dirs not found, left out)"
    return (
        f"Cost, measured from the runs: training {cost['training_core_h']:.1f} core-hours over {cost['stages']} "
        f"distinct stages, evaluation {cost['evaluation_core_h']:.1f} core-hours over {cost['jobs']} jobs{note}: "
        f"{cost['machine_h']:.1f} hours of this {cost['cores']}-core machine with every core busy"
    )
