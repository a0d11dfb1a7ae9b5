"""`mapush sweep`, `ablate` and `scale`: Hydra multiruns of sweep jobs (`pipeline.run_job`) through a launcher.

The sweep's axes come from the experiment file (`sweep:` lists and the budget's seeds) unless given on the
command line as comma lists (`sweep_axes.py` reads them). Every job gets a fixed dir named by its overrides under
`<sweep_root>/<experiment>_<budget>/`, so running the same command again skips the finished jobs and resumes the
cut ones. A job that fails writes `failed.txt` and lets the others run; the failures are listed at the end.
"""

from __future__ import annotations

import os
import sys
import traceback
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from mapush.config import CONF_DIR, compose_config, load_run_config
from mapush.errors import BadInput
from mapush.experiments import stages
from mapush.experiments.archive import archived_result, job_made_already, load_results, result_roots
from mapush.experiments.results import RESULT, SUPERSEDED, read_result
from mapush.experiments.staleness import result_changes
from mapush.experiments.sweep_axes import planned_jobs, split_axes, sweep_overrides
from mapush.experiments.workers import SWEEP_PID, job_threads, stop_with_the_sweep

FAILED = "failed.txt"


@hydra.main(config_path=str(CONF_DIR), config_name="sweep", version_base="1.3")
def job(cfg: DictConfig) -> str:
    """One sweep job in its Hydra output dir. A failure is written to `failed.txt` and the other jobs run on; only an
    interrupt, or the sweep's own end, stops the worker."""
    from mapush.experiments.pipeline import run_job  # training's machinery (PyTorch): loaded where jobs run

    job_dir = Path(HydraConfig.get().runtime.output_dir)
    (job_dir / FAILED).unlink(missing_ok=True)
    between_jobs = stop_with_the_sweep()
    between_jobs.clear()
    try:
        run_job(cfg, job_dir, job_threads(cfg))
        return "ok"
    except BaseException as err:  # the job reports and returns; an interrupt, or its sweep gone, ends the process
        (job_dir / FAILED).write_text("".join(traceback.format_exception(err)))
        if isinstance(err, KeyboardInterrupt) or (isinstance(err, SystemExit) and between_jobs.sweep_gone):
            raise
        return f"failed: {err}"
    finally:
        between_jobs.set()


def dry_run(overrides: list[str]) -> list[dict]:
    """What `run_sweep(overrides)` would train and reuse, job by job, training nothing; printed and returned.

    Finished jobs are left out (those whose experiment changed since are listed; see `rerun_changed`), and so are
    jobs another sweep's job made already (`archive.job_made_already`), whose results the sweep takes. Each row of
    the others: job, stage, identity, `action` (`train`, `resume` from `done` of its `iterations`, `reuse` a finished
    stage, `share` a stage an earlier job of this sweep trains, or `train_on` from `done` iterations of a finished
    stage that is this one with a shorter budget, `stages.shorter_twin`) and the stage's env-steps.
    """
    jobs = list(planned_jobs(sweep_overrides(overrides)))
    hydra_cfg = compose_config(jobs[0].combo, config_name="sweep", hydra=True).hydra
    unnamed = set(hydra_cfg.job.config.override_dirname.exclude_keys)  # keys the job dirs' names leave out
    rows, seen, changed, finished, taken = [], set(), [], 0, 0
    roots = result_roots(jobs[0].cfg)
    finished_results = load_results(roots)
    rates = stages.cost_per_env_step(finished_results, roots)
    for planned_job in jobs:
        cfg, planned, job = planned_job.cfg, planned_job.stages, planned_job.name(unnamed)
        result = Path(hydra_cfg.sweep.dir) / job / RESULT
        archived = None if result.is_file() else archived_result(cfg, result.parent, planned)
        if archived is not None and archived[1] is None:
            finished += 1  # finished on another machine, and archived (`mapush archive`)
            continue
        if not result.is_file() and job_made_already(cfg, result.parent, planned, finished_results) is not None:
            finished, taken = finished + 1, taken + 1  # made already by another sweep's job
            continue
        running_again = (result.parent / SUPERSEDED).is_file()  # cut while running again: it goes on
        if result.is_file() or (archived is not None and not running_again):
            why = result_changes(read_result(result), cfg, planned) if result.is_file() else archived[1]
            finished += 1
            if not why:
                continue  # finished as planned now: nothing to train or evaluate
            changed.append(f"{job}: {why}")
            if not cfg.rerun_changed:
                continue
        identities = {stage.name: stage.identity for stage in planned}
        for stage in planned:
            done = stages.trained_iterations(stages.stage_dir(Path(cfg.sweep_root), stage.identity))
            action = "share" if stage.identity in seen else "reuse" if done is None else "resume" if done else "train"
            twin = None if action != "train" else \
                stages.shorter_twin(Path(cfg.sweep_root), stage.cfg, stage.overrides, identities)  # fmt: skip
            if twin is not None:
                action, done = "train_on", int(load_run_config(twin).train.iterations)
            left = 0.0 if action in ("share", "reuse") else stage.env_steps * (1 - done / stage.iterations)
            rate = rates.get(stage.shape)
            seen.add(stage.identity)
            rows.append({"job": job, "stage": stage.name, "identity": stage.identity, "action": action, "done": done,
                         "iterations": stage.iterations, "env_steps": stage.env_steps,
                         "core_s": None if rate is None else (rate[0] * left, rate[1] * left)})  # fmt: skip
    to_train = [r for r in rows if r["action"] in TRAINS]
    made = f" ({taken} made already by other sweeps' jobs, their results to be taken)" if taken else ""
    print(f"sweep {hydra_cfg.sweep.dir}: {len(jobs)} jobs, {finished} finished{made}; {len(rows)} stages to run; "
          f"{len(to_train)} to train ({sum(r['env_steps'] for r in to_train) / 1e6:.1f}M env-steps), "
          f"{sum(r['action'] == 'reuse' for r in rows)} finished to reuse, "
          f"{sum(r['action'] == 'share' for r in rows)} shared between jobs")  # fmt: skip
    if to_train:
        print(_estimate_line(to_train))
    if changed:
        print(
            f"{len(changed)} finished jobs were made by other stages or evaluations than planned now; "
            + ("they run again:" if cfg.rerun_changed else "kept as they are (rerun_changed=true runs them again):")
        )
        for line in changed:
            print(f"  {line}")
    width = max((len(r["job"]) for r in rows), default=0)
    for r in rows:
        hours = "" if r["action"] in ("reuse", "share") else "  no measured stage like it" if r["core_s"] is None \
            else f"  ~{_hours(*r['core_s'], 2)} core-h"  # fmt: skip
        print(f"  {r['job']:{width}s}  {r['stage']:5s} {r['identity']}  {_action_text(r):18s} "
              f"{r['env_steps'] / 1e6:8.2f}M env-steps{hours}")  # fmt: skip
    return rows


TRAINS = ("train", "resume", "train_on")
"""A dry run's actions that train: from scratch, from the stage's last checkpoint, on from a shorter twin."""


def _action_text(row: dict) -> str:
    done = f" {row['done']}/{row['iterations']}" if row["action"] in ("resume", "train_on") else ""
    return {"resume": "resume from", "train_on": "train on"}.get(row["action"], row["action"]) + done


def _estimate_line(to_train: list[dict]) -> str:
    """The training time the dry run expects: measured core-seconds per env-step of finished stages of the same
    `stages.shape`, times the env-steps each stage has left."""
    known = [r["core_s"] for r in to_train if r["core_s"] is not None]  # (lowest, highest) core-seconds
    like = "of the same level, object, robots, envs and low level"
    if not known:
        return f"  training time: not estimated (no finished stage {like} has a measured time)"
    unknown = len(to_train) - len(known)
    return (
        f"  training time, estimated from finished stages {like} (the lowest and highest core-seconds per env-step "
        f"they took): {_hours(sum(lo for lo, _ in known), sum(hi for _, hi in known), 1)} core-hours for "
        f"{len(known)} of the {len(to_train)} stages to train"
        + (f" ({unknown} not estimated: no measured stage like them)" if unknown else "")
    )


def _hours(low_s: float, high_s: float, digits: int) -> str:
    """Core-seconds as hours, one figure where the range rounds to one, else "low-high"."""
    low, high = f"{low_s / 3600:.{digits}f}", f"{high_s / 3600:.{digits}f}"
    return low if low == high else f"{low}-{high}"


def run_sweep(overrides: list[str]) -> tuple[Path, list[Path], list[Path]]:
    """Launch the multirun; returns the sweep dir, the finished job dirs and the failed job dirs."""
    full = sweep_overrides(overrides)
    planned_jobs(full)  # remembered (`plan_memo`): a dry run of this sweep, finished or not, answers in seconds
    os.environ[SWEEP_PID] = str(os.getpid())  # the workers it starts exit with it
    argv = sys.argv
    sys.argv = [argv[0], "--multirun", *full]
    try:
        job()
    except SystemExit as err:  # hydra exits on its own errors
        if err.code:
            raise BadInput(f"the sweep did not launch (hydra exit {err.code}); see the message above") from None
    finally:
        sys.argv = argv
    sweep_dir = _sweep_dir(full)
    finished = sorted(p.parent for p in sweep_dir.glob(f"*/{RESULT}"))
    failed = sorted(p.parent for p in sweep_dir.glob(f"*/{FAILED}"))
    return sweep_dir, finished, failed


def _sweep_dir(overrides: list[str]) -> Path:
    """The multirun's dir: the same for every job, so the first value of each axis will do."""
    first = [f"{key}={values[0]}" for key, values in split_axes(overrides).items()]
    return Path(compose_config(first, config_name="sweep", hydra=True).hydra.sweep.dir)


def report(sweep_dir: Path, finished: list[Path], failed: list[Path]) -> int:
    """Print the sweep's outcome; returns the exit code (1 when a job failed)."""
    print(f"sweep {sweep_dir}: {len(finished)} jobs finished, {len(failed)} failed")
    for path in finished:
        result = read_result(path / RESULT)
        cells = ", ".join(
            f"{name} S.R. {100 * e.success_rate:.1f}% C.T. {e.completion_time:.3f}" for name, e in result.evals.items()
        )
        print(f"  {path.name}: {cells}")
    for path in failed:
        last = (path / FAILED).read_text().strip().splitlines()[-1]
        print(f"  FAILED {path.name}: {last} (traceback in {path / FAILED})")
    return 1 if failed else 0
