"""One sweep job: train a method's stages in order, run the experiment's evaluations (of the evaluated stage, or
of another trained stage an evaluation names), write `result.json`.

Stages live in the sweep root's store (`stages.py`), one run per stage identity, shared by every job and
experiment that composes the same stage; a job dir holds `result.json`, which names the run dir of each stage.
Re-running a job keeps its `result.json` while the experiment plans the job as it was made (else it says so, and
with `rerun_changed` runs it again); so does a job whose result is only in the archive (`mapush archive`), its runs
gone: run again, it keeps the archived result as the one it supersedes. It reuses stages whose run is finished (it
has the exported policy), resumes a stage cut after a checkpoint, and restarts one cut before.

Besides the evaluated stage's learning curve (`curve`), a budget may ask for the curves of the stages trained
before it (`curve.stages`, e.g. the mid level under a high level): each is drawn once, on the stage's own env, into
its run dir (`STAGE_CURVE`) and copied into the result of every job that uses the stage (`stage_curves`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import json
import os
import shutil
import time
from pathlib import Path

import torch
from omegaconf import DictConfig, OmegaConf

from mapush import training
from mapush.atomic import write_json
from mapush.config import apply_overrides, compose_config, lengthen_run, load_run_config, to_plain
from mapush.errors import BadInput
from mapush.eval.curves import learning_curve
from mapush.eval.rollout import evaluate
from mapush.experiments import stages
from mapush.experiments.archive import archived_result, job_made_already
from mapush.experiments.job_records import Curve, CurveRule
from mapush.experiments.results import (
    RESULT,
    SUPERSEDED,
    JobResult,
    read_result,
    recorded_stage_seconds,
    write_result,
)
from mapush.experiments.stage_plan import (
    applies,
    budget_of,
    eval_overrides,
    eval_stage,
    evaluated_stage,
    planned_stages,
    stage_curve_specs,
    variant,
)
from mapush.experiments.stages import STAGE_REF
from mapush.experiments.staleness import drawn_alike, result_changes, still_valid
from mapush.rundir import META_FILE, ONNX_FILE, PACKAGE, POLICY_FILE, checkpoints, find_runs, is_complete

LOADED_AT = time.time()
"""When this process imported mapush: a sweep's workers keep the code they started with for every job they run,
but read the config files anew for each job."""


STAGE_CURVE = "stage_curve.json"
"""A stage's own learning curve, in its run dir: drawn once for every job that uses the stage."""


def check_code_unchanged() -> None:
    """Refuse a job when mapush's Python files changed after this process imported them (an editable install edited
    while a sweep runs): its old code would read the new config files and name stages by neither version."""
    changed = sorted(p for p in PACKAGE.rglob("*.py") if p.stat().st_mtime > LOADED_AT)
    if changed:
        names = ", ".join(str(p.relative_to(PACKAGE.parent)) for p in changed[:3])
        more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        raise BadInput(
            f"mapush's code changed after this sweep started ({names}{more}); valid: the same sweep command again, "
            "which resumes with the new code"
        )


def run_job(cfg: DictConfig, job_dir: Path, threads: int) -> JobResult:
    """Train, evaluate and record one job; returns the result (also written to `job_dir/result.json`)."""
    check_code_unchanged()
    job_dir = Path(job_dir)
    done = job_dir / RESULT
    planned = planned_stages(cfg)
    earlier = None  # a result the experiment has changed under: what of it still holds is kept
    archived = None if done.is_file() else archived_result(cfg, job_dir, planned)
    if archived is not None and archived[1] is None:  # finished on another machine
        print(f"mapush: {job_dir.name}: finished as planned now, archived in {archived[0].parent}")
        return read_result(archived[0])
    made = None if done.is_file() else job_made_already(cfg, job_dir, planned)
    if made is not None:  # another sweep's job made all this one would
        print(f"mapush: {job_dir.name}: made already as {made[0].job_dir}; its result taken, nothing trained")
        return write_result(done, _taken(cfg, job_dir, *made))
    if archived is not None and not (job_dir / SUPERSEDED).is_file():  # made otherwise, on a machine now gone
        path, changed = archived
        if not cfg.rerun_changed:
            print(f"mapush: {job_dir.name}: {changed} since its archived {RESULT}; kept (rerun_changed=true runs it "
                  "again)")  # fmt: skip
            return read_result(path)
        print(f"mapush: {job_dir.name}: {changed} since its archived {RESULT}; running again what changed "
              f"({SUPERSEDED} keeps the archived one)")  # fmt: skip
        job_dir.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, job_dir / SUPERSEDED)
    if done.is_file():
        result = read_result(done)
        changed = result_changes(result, cfg, planned)
        if not changed:
            return _with_stage_curves(result, cfg, done)
        if not cfg.rerun_changed:
            print(f"mapush: {job_dir.name}: {changed} since its {RESULT}; kept (rerun_changed=true runs it again)")
            return result
        print(f"mapush: {job_dir.name}: {changed} since its {RESULT}; running again what changed ({SUPERSEDED} "
              "keeps the old)")  # fmt: skip
        os.replace(done, job_dir / SUPERSEDED)
        earlier = result
    if earlier is None and (job_dir / SUPERSEDED).is_file():  # cut while running again
        earlier = read_result(job_dir / SUPERSEDED)
    kept, kept_curve = still_valid(earlier, cfg, planned) if earlier else ({}, None)
    torch.set_num_threads(threads)
    budget = budget_of(cfg)
    runs: dict[str, Path] = {}
    root, identities = Path(cfg.sweep_root), {stage.name: stage.identity for stage in planned}
    for stage in planned:
        overrides = [_resolve_stage_refs(o, runs) for o in stage.overrides] + [f"sim.nthread={threads}"]
        directory = stages.stage_dir(root, stage.identity)
        with stages.held(directory):
            new = stages.trained_iterations(directory) == 0  # as the dry run judges it
            twin = stages.shorter_twin(root, stage.cfg, stage.overrides, identities) if new else None
            runs[stage.name] = train_stage(directory, overrides, stage.iterations, stage.save_interval, threads, twin)
    evaluated = runs[evaluated_stage(cfg)]
    started = time.perf_counter()  # the evaluations and the learning curve: the job's cost beside its stages'
    evals = {}
    for name, spec in cfg.experiment.evals.items():
        if not applies(spec, cfg.method.name):
            continue  # an evaluation for other methods only
        if name in kept:
            evals[name] = kept[name]
            continue
        target = runs[eval_stage(cfg, spec)]
        overrides = eval_overrides(cfg, name)
        path = evaluate(target, int(budget.eval.episodes), list(budget.eval.seeds), list(overrides), name=name,
                        reuse=True)  # made before the job was cut: kept  # fmt: skip
        evals[name] = {k: v for k, v in json.loads(path.read_text()).items() if k != "per_seed"}
        evals[name]["file"] = str(path)
        evals[name]["overrides"] = list(overrides)
    result = _job_result(
        cfg,
        job_dir,
        **trained_under(load_run_config(evaluated)),
        stages={name: str(path) for name, path in runs.items()},  # in the shared store: maybe another job's
        stage_core_s=recorded_stage_seconds(runs),
        evals=evals,
        curve=kept_curve or _curve(cfg, evaluated),
        stage_curves=stage_curves(cfg, runs),
        eval_wall_s=round(time.perf_counter() - started, 1),  # this run's; `supersedes` names the earlier's
        threads=threads,
        machine_cores=os.cpu_count(),
        supersedes=None if earlier is None else SUPERSEDED,  # its evaluations are kept where they hold
    )
    return write_result(done, result)


def trained_under(run: DictConfig) -> dict:
    """What a job's result records of the setup its evaluated stage was trained in: robots, rules, low level."""
    return {
        "num_agents": int(run.task.num_agents),
        "rules": str(OmegaConf.select(run, "level.rules", default=None) or "strict"),  # runs before rules: strict
        "lowlevel": str(run.lowlevel.name),
    }


def _job_result(cfg: DictConfig, job_dir: Path, **made) -> JobResult:
    """The result of the job `cfg` composes, in `job_dir`, with what it `made` (stages, evaluations, curves, cost)."""
    result = JobResult(
        experiment=cfg.experiment.name,
        table=cfg.experiment.table,
        budget=cfg.budget,
        variant=variant(cfg),
        overrides=list(cfg.overrides),
        method=cfg.method.name,
        method_label=cfg.method.label,
        task=cfg.task.name,
        seed=int(cfg.seed),
        finished=datetime.datetime.now().isoformat(timespec="seconds"),
        job_dir=str(job_dir),
        **made,
    )
    result.object_physics()  # the object and one robot, as its stages' records hold them (`job_physics`)
    for name, evaluation in result.evals.items():
        evaluation.object_mass_kg = result.object_mass(name)
    return result


def _taken(cfg: DictConfig, job_dir: Path, other: JobResult, evals: dict, curve: dict | None) -> JobResult:
    """This job's result from `other`, another sweep's job that made it (`archive.job_made_already`): its stages and
    their training time, the evaluations and curves this job asks for; no evaluation time, as this job evaluated
    nothing (the other job's result counts it)."""
    runs = {name: Path(run) for name, run in other.stages.items()}
    return _job_result(
        cfg,
        job_dir,
        num_agents=other.num_agents,
        rules=other.rules,
        lowlevel=other.lowlevel,
        stages=dict(other.stages),
        stage_core_s=dict(other.stage_core_s),
        evals=evals,
        curve=curve,
        stage_curves=stage_curves(cfg, runs, other.stage_curves),
        eval_wall_s=0.0,
        threads=other.threads,
        machine_cores=other.machine_cores,
        taken_from=other.job_dir,
    )


def stage_curves(cfg: DictConfig, runs: dict[str, Path], have: dict | None = None) -> dict[str, Curve]:
    """The learning curves of the stages the budget's `curve.stages` names that the job trains before its evaluated
    stage: each stage's checkpoints evaluated on its own env (the mid level alone, on its 20 s pushes), at the
    curve's marks, with the budget's evaluation seeds and the stage's `episodes` (by default the budget's), and the
    experiment's budget rule.

    A stage's curve is drawn once, into its run dir (`STAGE_CURVE`), and read from there by every other job that
    uses the stage. A stage whose run is not here keeps the curve `have` holds for it (an earlier result's), if
    that was drawn alike; otherwise it has none.
    """
    rule = OmegaConf.to_container(cfg.experiment.budget_rule)
    drawn = {}
    for name, spec in stage_curve_specs(cfg, set(runs)).items():
        earlier = (have or {}).get(name)
        if Path(runs[name]).is_dir():
            drawn[name] = Curve.from_record(
                {**spec, "rule": rule, "points": _stage_curve_points(Path(runs[name]), spec)}
            )
        elif drawn_alike(earlier, spec):
            drawn[name] = dataclasses.replace(earlier, rule=CurveRule(**rule))  # judged by today's rule
    return drawn


def _stage_curve_points(run_dir: Path, spec: dict) -> list[dict]:
    """The points of a stage's own learning curve drawn as `spec` says, written into its run dir: those drawn alike
    before read from there (all of them, or those of the shorter stage it was trained on from), the rest drawn."""
    path = run_dir / STAGE_CURVE
    drawn = []
    with contextlib.suppress(OSError, ValueError):
        earlier = json.loads(path.read_text())
        drawn = earlier["points"] if drawn_alike(earlier, spec) else []
    cfg = to_plain(load_run_config(run_dir))
    points = learning_curve(run_dir, cfg, spec["every_env_steps"], spec["episodes"], spec["seeds"], drawn)
    if points != drawn:
        write_json(path, {**spec, "points": points})
    return points


def _with_stage_curves(result: JobResult, cfg: DictConfig, path: Path) -> JobResult:
    """A finished job's `result` with the stage curves its budget asks for now and it lacks, drawn where the stage
    runs are here (the evaluation time counted in `eval_wall_s`) and written back to `path`."""
    started = time.perf_counter()
    runs = {name: Path(run) for name, run in result.stages.items()}
    curves = stage_curves(cfg, runs, result.stage_curves)
    if curves == (result.stage_curves or {}):
        return result
    result.stage_curves = curves
    result.eval_wall_s = round(float(result.eval_wall_s or 0.0) + time.perf_counter() - started, 1)
    return write_result(path, result)


def _curve(cfg: DictConfig, evaluated: Path) -> dict | None:
    """The budget's `curve`: the evaluated stage's checkpoints evaluated as the named evaluation, with the
    experiment's budget rule; None when the budget asks for none."""
    budget = budget_of(cfg)
    curve = budget.get("curve")
    if not curve:
        return None
    run_cfg = to_plain(apply_overrides(load_run_config(evaluated), eval_overrides(cfg, curve.eval)))
    episodes, seeds = int(budget.eval.episodes), list(budget.eval.seeds)
    points = learning_curve(evaluated, run_cfg, float(curve.every_env_steps), episodes, seeds)
    rule = OmegaConf.to_container(cfg.experiment.budget_rule)
    return {**OmegaConf.to_container(curve), "rule": rule, "points": points}


def train_stage(
    stage_dir: Path, overrides: list[str], iterations: int, save_interval: int, threads: int, twin: Path | None = None
) -> Path:
    """The finished run of one stage in its store dir: reused, resumed from its last checkpoint (with the job's
    `threads`, not those of the process it was cut in), trained on from `twin` (the run of the same stage with a
    shorter budget, `stages.shorter_twin`), or trained from scratch for `iterations`."""
    for run_dir in find_runs(stage_dir):
        if (run_dir / POLICY_FILE).is_file():
            return run_dir
        if is_complete(run_dir):
            return training.export_finished(run_dir)
        if checkpoints(run_dir):
            return training.resume(run_dir, None, threads)
        shutil.rmtree(run_dir)  # cut before its first checkpoint: nothing to keep
    cfg = compose_config(overrides)
    budget = {
        "train.iterations": iterations,
        "train.run_root": str(stage_dir),
        "train.progress": False,
        "algo.keep_checkpoints": 0,  # every checkpoint: the learning curve evaluates the last before each mark
        "algo.save_interval": save_interval,
    }
    for key, value in budget.items():
        OmegaConf.update(cfg, key, value)
    overrides = [*overrides, *(f"{key}={value}" for key, value in budget.items())]  # the run's record
    command = f"mapush sweep (stage of {stage_dir.parent})"
    if twin is not None:
        return _train_on(twin, stage_dir, to_plain(cfg), threads, command)
    stages.write_identity(stage_dir, to_plain(cfg), stage_dir.name)
    return training.train(cfg, overrides, command=command)


def _train_on(twin: Path, stage_dir: Path, cfg: dict, threads: int, command: str) -> Path:
    """The stage's run made by training its shorter `twin` on: a copy of the twin's run (checkpoints hard-linked,
    the points of its own curve kept for the checkpoints they share; its exported policy left behind, as it holds
    the twin's end) lengthened to the stage's iterations (`lengthen_run`), then resumed. Its `stage.yaml` names the
    twin (`lengthened_from`)."""
    target = Path(stage_dir).joinpath(*stages.store_parts(twin)[2:])  # level, subject, run: as the twin's
    if target.exists():
        shutil.rmtree(target)  # a copy cut before its meta.json made it a run
    stages.copy_run(twin, target, leave=(META_FILE, POLICY_FILE, ONNX_FILE))
    lengthen_run(target, int(cfg["train"]["iterations"]), command, meta_from=twin / META_FILE)
    origin = {"identity": stages.identity_of(twin), "iterations": int(load_run_config(twin).train.iterations)}
    stages.write_identity(stage_dir, cfg, Path(stage_dir).name, lengthened_from=origin)
    print(f"mapush: stage {Path(stage_dir).name} trains on from stage {origin['identity']} ({twin})")
    return training.resume(target, None, threads)


def _resolve_stage_refs(override: str, runs: dict[str, Path]) -> str:
    if not stages.is_ref(override):
        return override
    key, _, value = override.partition("=")
    stage = value[len(STAGE_REF) :]
    if stage not in runs:
        raise BadInput(f"override {override!r} refers to stage {stage!r}, not trained before it")
    return f"{key}={quoted(runs[stage])}"


def quoted(path: Path) -> str:
    """A path as a quoted Hydra override value (job dirs hold `=` and `,`)."""
    text = str(path)
    if "'" in text:
        raise BadInput(f"path {text!r} holds a single quote; valid: a sweep_root and overrides without quotes")
    return f"'{text}'"
