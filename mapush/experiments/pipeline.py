"""One sweep job: train a method's stages in order, run the experiment's evaluations (of the evaluated stage, or
of another trained stage an evaluation names), write `result.json`.

Stages live in the sweep root's store (`stages.py`), one run per stage identity, shared by every job and
experiment that composes the same stage; a job dir holds `result.json`, which names the run dir of each stage.
Re-running a job skips it when `result.json` exists, reuses stages whose run is finished (it has the exported
policy), resumes a stage cut after a checkpoint, and restarts one cut before.

Besides the evaluated stage's learning curve (`curve`), a budget may ask for the curves of the stages trained
before it (`curve.stages`, e.g. the mid level under a high level): each is drawn once, on the stage's own env, into
its run dir (`STAGE_CURVE`) and copied into the result of every job that uses the stage (`stage_curves`).
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import os
import re
import shutil
import time
from pathlib import Path
from typing import NamedTuple

import torch
from omegaconf import DictConfig, OmegaConf

from mapush import train as training
from mapush.atomic import write_json
from mapush.config import apply_overrides, compose_config, group_file, group_options, load_run_config, to_plain
from mapush.errors import BadInput
from mapush.eval.curves import learning_curve
from mapush.eval.rollout import evaluate
from mapush.experiments import stages
from mapush.experiments.stages import STAGE_REF
from mapush.lowlevel import backend_of
from mapush.rl.runner import POLICY_FILE, env_steps_per_iteration
from mapush.rundir import PACKAGE, checkpoints, find_runs, is_complete

LOADED_AT = time.time()
"""When this process imported mapush: a sweep's workers keep the code they started with for every job they run,
but read the config files anew for each job."""
RESULT = "result.json"
SUPERSEDED = "result.superseded.json"
"""Where a job's earlier result goes when the experiment changed under it (`result_changes`)."""
STAGE_CURVE = "stage_curve.json"
"""A stage's own learning curve, in its run dir: drawn once for every job that uses the stage."""
STAGE_BUDGET_KEYS = ("num_envs", "env_steps")
"""What a budget sets for each stage (and what a stage's `by_task` entry may set for one task)."""


def stage_plan(cfg: DictConfig) -> list[tuple[str, list[str]]]:
    """The stages to train, up to the evaluated one, each with every override it is composed with.

    Order: the method's common overrides, the experiment's (`overrides`, where it has them), the stage's, the job's
    task / seed / agents / extra overrides, then the budget's num_envs (env-steps become `train.iterations` in
    `train_stage`).
    """
    method, experiment = cfg.method, cfg.experiment
    names = list(method.stages)
    evaluated = evaluated_stage(cfg)
    if evaluated not in names:
        raise BadInput(
            f"experiment {experiment.name!r} evaluates stage {evaluated!r}, which method "
            f"{method.name!r} lacks; valid stages: {', '.join(names)}"
        )
    trained = names[: names.index(evaluated) + 1]
    for name, spec in experiment.evals.items():
        if applies(spec, method.name) and eval_stage(cfg, spec) not in trained:
            raise BadInput(
                f"experiment {experiment.name!r} evaluation {name!r} runs stage {eval_stage(cfg, spec)!r}, which "
                f"its {method.name!r} jobs do not train (they stop at {evaluated!r}); valid stages: "
                f"{', '.join(trained)}"
            )
    curve = budget_of(cfg).get("curve")
    if curve and curve.eval not in experiment.evals:
        raise BadInput(f"budget {cfg.budget!r} curve eval {curve.eval!r}; valid: {', '.join(experiment.evals)}")
    if curve and eval_stage(cfg, experiment.evals[curve.eval]) != evaluated:
        raise BadInput(
            f"budget {cfg.budget!r} draws its learning curve with evaluation {curve.eval!r}, which runs another "
            f"stage than the evaluated {evaluated!r}; valid: an evaluation of {evaluated!r}"
        )
    known = {name for method in group_options("method") for name in group_file("method", method).stages}
    unknown = [name for name in (curve.get("stages", {}) if curve else {}) if name not in known]
    if unknown:
        raise BadInput(f"budget {cfg.budget!r} curve stage {unknown[0]!r}; valid: {', '.join(sorted(known))}")
    job = [f"task={cfg.task.name}", f"seed={cfg.seed}"]
    if cfg.agents is not None:
        job.append(f"task.num_agents={cfg.agents}")
    plan = []
    for name in trained:
        shared = experiment.get("overrides", [])  # every stage of every job of this experiment
        overrides = [*method.overrides, *shared, *method.stages[name], *job, *cfg.overrides]
        overrides.append(f"num_envs={stage_budget(cfg, name).num_envs}")
        plan.append((name, overrides))
    return plan


def evaluated_stage(cfg: DictConfig) -> str:
    """The stage whose policy the job evaluates: the experiment's `evaluate`, or else the method's last stage."""
    return cfg.experiment.evaluate or list(cfg.method.stages)[-1]


def budget_of(cfg: DictConfig) -> DictConfig:
    """The experiment's budget named by `cfg.budget`; BadInput naming the valid ones."""
    budgets = cfg.experiment.budgets
    if cfg.budget not in budgets:
        raise BadInput(f"unknown budget {cfg.budget!r}; valid: {', '.join(budgets)}")
    return budgets[cfg.budget]


def stage_budget(cfg: DictConfig, name: str) -> DictConfig:
    """The budget's `num_envs` and `env_steps` for stage `name` of the job's task: the stage's entry, with the
    task's own values from its `by_task` where the task has some (a stage that learns more slowly on one object).

    With the budget's `same_learning_as: METHOD`, every method learns for as many env-steps as METHOD's stages
    together: its last stage gets that total less what its earlier stages learn (H+L's one high level learns as
    long as Ours' mid and high levels together)."""
    own = _stage_entry(cfg, name)
    reference = budget_of(cfg).get("same_learning_as")
    method_stages = list(cfg.method.stages)
    if not reference or name != method_stages[-1] or cfg.method.name == reference:
        return own
    if reference not in group_options("method"):
        raise BadInput(
            f"budget {cfg.budget!r}: same_learning_as {reference!r}; valid: {', '.join(group_options('method'))}"
        )
    total = sum(float(_stage_entry(cfg, stage).env_steps) for stage in group_file("method", reference).stages)
    earlier = sum(float(_stage_entry(cfg, stage).env_steps) for stage in method_stages[:-1])
    if total <= earlier:
        raise BadInput(f"budget {cfg.budget!r}: {cfg.method.name}'s stages before {name!r} already learn as long as "
                       f"{reference}'s; valid: a same_learning_as method that learns longer")  # fmt: skip
    return OmegaConf.create({"num_envs": own.num_envs, "env_steps": total - earlier})


def _stage_entry(cfg: DictConfig, name: str) -> DictConfig:
    """`stage_budget` as the budget writes it for stage `name` and the job's task."""
    budget = budget_of(cfg)
    if name not in budget.stages:
        raise BadInput(f"budget {cfg.budget!r} of experiment {cfg.experiment.name!r} has no stage {name!r}")
    entry = budget.stages[name]
    by_task = entry.get("by_task", {})
    for task, own in by_task.items():
        unknown = [f"{task}.{key}" for key in own if key not in STAGE_BUDGET_KEYS]
        if task not in group_options("task") or unknown:
            raise BadInput(
                f"budget {cfg.budget!r} stage {name!r}: unknown by_task entry {(unknown or [task])[0]!r}; valid: "
                f"tasks {', '.join(group_options('task'))}, each with num_envs and/or env_steps"
            )
    own = by_task.get(cfg.task.name, {})
    return OmegaConf.create({key: own.get(key, entry[key]) for key in STAGE_BUDGET_KEYS})


def variant(cfg: DictConfig) -> str:
    """The sweep's name without its experiment prefix (e.g. `quick`, `smoke_debug-smoke`): one table per variant."""
    name, prefix = str(cfg.sweep_name), f"{cfg.experiment.name}_"
    return name[len(prefix) :] if name.startswith(prefix) else name


class PlannedStage(NamedTuple):
    """A stage of a job as it will be trained: its overrides, budget in iterations and env-steps, identity, the
    iterations between its checkpoints, its `stages.shape` (what its time per env-step depends on) and its
    composed config (plain)."""

    name: str
    overrides: list[str]
    iterations: int
    env_steps: int
    identity: str
    save_interval: int
    shape: tuple
    cfg: dict


def planned_stages(cfg: DictConfig) -> list[PlannedStage]:
    """Every stage the job trains, in order, composed and identified without training anything."""
    budget = budget_of(cfg)
    identities: dict[str, str] = {}
    planned = []
    for name, overrides in stage_plan(cfg):
        env_steps = float(stage_budget(cfg, name).env_steps)
        stage_cfg = stages.compose_stage(overrides, lambda c, s=env_steps: iterations_for(c, s))
        identities[name] = stages.identity(stage_cfg, overrides, identities)
        iterations = int(stage_cfg["train"]["iterations"])
        per_iteration = env_steps_per_iteration(stage_cfg)
        save_interval = int(stage_cfg["algo"]["save_interval"])
        if budget.get("curve"):  # a checkpoint by every mark of the learning curve, which evaluates the last before it
            # (model_<k>.pt holds k + 1 iterations: one fewer than fit between two marks keeps each before its mark)
            fit = int(float(budget.curve.every_env_steps) // per_iteration)
            save_interval = min(save_interval, max(1, fit - 1))
        env_steps = iterations * per_iteration
        kind = stages.shape(stage_cfg)
        planned.append(
            PlannedStage(name, overrides, iterations, env_steps, identities[name], save_interval, kind, stage_cfg)
        )
    return planned


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


def iterations_for(stage_cfg: DictConfig | dict, env_steps: float) -> int:
    """PPO iterations that give at least `env_steps` 50 Hz control steps."""
    return max(1, math.ceil(float(env_steps) / env_steps_per_iteration(stage_cfg)))


def run_job(cfg: DictConfig, job_dir: Path, threads: int) -> dict:
    """Train, evaluate and record one job; returns the result (also written to `job_dir/result.json`)."""
    check_code_unchanged()
    job_dir = Path(job_dir)
    done = job_dir / RESULT
    planned = planned_stages(cfg)
    earlier = None  # a result the experiment has changed under: what of it still holds is kept
    archived = None if done.is_file() else archived_result(cfg, job_dir, planned)
    if archived is not None:  # finished on another machine
        print(f"mapush: {job_dir.name}: finished as planned now, archived in {archived.parent}")
        return json.loads(archived.read_text())
    if done.is_file():
        result = json.loads(done.read_text())
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
        earlier = json.loads((job_dir / SUPERSEDED).read_text())
    kept, kept_curve = still_valid(earlier, cfg, planned) if earlier else ({}, None)
    torch.set_num_threads(threads)
    budget = budget_of(cfg)
    runs: dict[str, Path] = {}
    for stage in planned:
        overrides = [_resolve_stage_refs(o, runs) for o in stage.overrides] + [f"sim.nthread={threads}"]
        directory = stages.stage_dir(Path(cfg.sweep_root), stage.identity)
        with stages.held(directory):
            runs[stage.name] = train_stage(directory, overrides, stage.iterations, stage.save_interval, threads)
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
        overrides = eval_overrides(spec)
        path = evaluate(target, int(budget.eval.episodes), list(budget.eval.seeds), list(overrides), name=name)
        evals[name] = {k: v for k, v in json.loads(path.read_text()).items() if k != "per_seed"}
        evals[name]["file"] = str(path)
        evals[name]["overrides"] = list(overrides)
    result = {
        "experiment": cfg.experiment.name,
        "table": cfg.experiment.table,
        "budget": cfg.budget,
        "variant": variant(cfg),
        "overrides": list(cfg.overrides),
        "method": cfg.method.name,
        "method_label": cfg.method.label,
        "task": cfg.task.name,
        "num_agents": int(load_run_config(evaluated).task.num_agents),
        "seed": int(cfg.seed),
        "stages": {name: str(path) for name, path in runs.items()},  # in the shared store: maybe another job's
        "stage_core_s": recorded_stage_seconds(runs),  # the training cost, kept when the runs are gone
        "evals": evals,
        "curve": kept_curve or _curve(cfg, evaluated),
        "stage_curves": stage_curves(cfg, runs),
        "eval_wall_s": round(time.perf_counter() - started, 1),  # this run's; `supersedes` names the earlier's
        "threads": threads,
        "machine_cores": os.cpu_count(),
        "finished": datetime.datetime.now().isoformat(timespec="seconds"),
    }
    if earlier is not None:
        result["supersedes"] = SUPERSEDED  # the result it replaces, whose evaluations it keeps where they hold
    return _write_json(done, result)


def _write_json(path: Path, data: dict) -> dict:
    """Write `data` (a job's result, a stage's curve) to `path` atomically; returns it."""
    write_json(path, data)
    return data


def stage_curves(cfg: DictConfig, runs: dict[str, Path], have: dict | None = None) -> dict[str, dict]:
    """The learning curves of the stages the budget's `curve.stages` names that the job trains before its evaluated
    stage: each stage's checkpoints evaluated on its own env (the mid level alone, on its 20 s pushes), at the
    curve's marks, with the budget's evaluation seeds and the stage's `episodes` (by default the budget's), and the
    experiment's budget rule.

    A stage's curve is drawn once, into its run dir (`STAGE_CURVE`), and read from there by every other job that
    uses the stage. A stage whose run is not here keeps the curve `have` holds for it (an earlier result's), if
    that was drawn alike; otherwise it has none.
    """
    budget = budget_of(cfg)
    curve = budget.get("curve")
    asked = curve.get("stages", {}) if curve else {}
    rule = OmegaConf.to_container(cfg.experiment.budget_rule)
    drawn = {}
    for name in (n for n in asked if n in runs and n != evaluated_stage(cfg)):
        spec = {
            "every_env_steps": float(curve.every_env_steps),
            "episodes": int((asked[name] or {}).get("episodes", budget.eval.episodes)),
            "seeds": [int(s) for s in budget.eval.seeds],
        }
        earlier = (have or {}).get(name)
        if Path(runs[name]).is_dir():
            drawn[name] = {**spec, "rule": rule, "points": _stage_curve_points(Path(runs[name]), spec)}
        elif _drawn_alike(earlier, spec):
            drawn[name] = {**earlier, "rule": rule}  # judged by today's rule
    return drawn


def _drawn_alike(curve: dict | None, spec: dict) -> bool:
    """Whether a recorded stage curve was drawn at the marks, episodes and seeds `spec` asks for."""
    return bool(curve) and {key: curve.get(key) for key in spec} == spec


def _stage_curve_points(run_dir: Path, spec: dict) -> list[dict]:
    """The points of a stage's own learning curve drawn as `spec` says: read from its run dir when drawn alike
    before, else drawn now and written there."""
    path = run_dir / STAGE_CURVE
    with contextlib.suppress(OSError, ValueError):
        drawn = json.loads(path.read_text())
        if _drawn_alike(drawn, spec):
            return drawn["points"]
    cfg = to_plain(load_run_config(run_dir))
    points = learning_curve(run_dir, cfg, spec["every_env_steps"], spec["episodes"], spec["seeds"])
    _write_json(path, {**spec, "points": points})
    return points


def _with_stage_curves(result: dict, cfg: DictConfig, path: Path) -> dict:
    """A finished job's `result` with the stage curves its budget asks for now and it lacks, drawn where the stage
    runs are here (the evaluation time counted in `eval_wall_s`) and written back to `path`."""
    started = time.perf_counter()
    runs = {name: Path(run) for name, run in result.get("stages", {}).items()}
    curves = stage_curves(cfg, runs, result.get("stage_curves"))
    if curves == result.get("stage_curves", {}):
        return result
    result["stage_curves"] = curves
    result["eval_wall_s"] = round(float(result.get("eval_wall_s", 0.0)) + time.perf_counter() - started, 1)
    return _write_json(path, result)


def archived_result(cfg: DictConfig, job_dir: Path, planned: list[PlannedStage]) -> Path | None:
    """The job's `result.json` in the archive (`cfg.archive`, `mapush archive`), if it is there and finished as the
    experiment plans the job now (`planned`): such a job is done, though its runs are on another machine or gone."""
    if not cfg.get("archive"):
        return None
    archive = Path(cfg.archive)
    path = archive / Path(job_dir).parent.name / Path(job_dir).name / RESULT
    if not path.is_file():
        return None
    return None if result_changes(json.loads(path.read_text()), cfg, planned, archive) else path


def recorded_stage_seconds(runs: dict[str, Path]) -> dict[str, float]:
    """Each stage's training core-seconds as its run records them now (`stages.stage_core_seconds`); a stage whose
    logs cannot be read is left out."""
    seconds = {}
    for name, path in runs.items():
        with contextlib.suppress(BadInput, OSError):
            seconds[name] = round(stages.stage_core_seconds(path), 3)  # a smoke iteration can take < 0.05 s
    return seconds


def still_valid(result: dict, cfg: DictConfig, planned: list[PlannedStage]) -> tuple[dict, dict | None]:
    """Of an earlier `result`, the evaluations (and the learning curve) that hold under the experiment now: made of
    a stage with the same identity (or one it was adopted from), with the same overrides and locomotion policy.
    An evaluation that recorded no overrides (made before they were recorded) is taken as made with today's, as
    `result_changes` takes it."""
    same = _same_stages(result, cfg, planned)
    kept = {}
    for name, spec in cfg.experiment.evals.items():
        record = result.get("evals", {}).get(name)
        holds = record and applies(spec, cfg.method.name) and eval_stage(cfg, spec) in same
        holds = holds and record.get("overrides", eval_overrides(spec)) == eval_overrides(spec)
        if holds and not _walker_changed(record, result, cfg, name, planned):
            kept[name] = {**record, "overrides": eval_overrides(spec)}
    curve, spec = result.get("curve"), budget_of(cfg).get("curve")
    holds = curve and spec and evaluated_stage(cfg) in same and curve.get("eval") in kept
    if not holds or curve.get("every_env_steps") != spec.every_env_steps:
        return kept, None
    return kept, {**curve, "rule": OmegaConf.to_container(cfg.experiment.budget_rule)}  # judged by today's rule


def _walker_changed(record: dict, result: dict, cfg: DictConfig, name: str, planned: list[PlannedStage]) -> bool:
    """Whether the locomotion policy evaluation `name` would walk its robots with now (`lowlevel.policy`, or the
    shipped one) is another than the one its `record` names; a legged evaluation that named none counts as
    changed. The stage's run config says which policy, or where the run is gone (another machine, an archived
    job), the stage's config as the experiment plans it now."""
    spec = cfg.experiment.evals[name]
    stage = eval_stage(cfg, spec)
    run = result.get("stages", {}).get(stage)
    if run and Path(run).is_dir():
        stage_cfg = load_run_config(run)
    else:
        stage_cfg = OmegaConf.create(next(p.cfg for p in planned if p.name == stage))
    lowlevel = to_plain(apply_overrides(stage_cfg, eval_overrides(spec)))["lowlevel"]
    now = backend_of(lowlevel).policy_fingerprint(lowlevel)
    # the policy's hash says which it is; its file's path moves with the checkout
    return (now or {}).get("sha256") != (record.get("lowlevel_policy") or {}).get("sha256")


def _same_stages(result: dict, cfg: DictConfig, planned: list[PlannedStage], root: Path | None = None) -> set[str]:
    """Names of the planned stages that `result` was made with: the same identity, or one the planned stage was
    adopted from (`stages.stands_for`, read from the store under `root`, by default the sweep root)."""
    made = {name: stages.identity_of(Path(path)) for name, path in result.get("stages", {}).items()}
    root = Path(cfg.sweep_root if root is None else root)
    return {s.name for s in planned if made.get(s.name) in stages.stands_for(root, s.identity)}


def _about_evaluation(name: str, what: str) -> str:
    """A `result_changes` reason that concerns one evaluation only; `concerns` reads its name back."""
    return f"evaluation {name!r} {what}"


def _about_stages(changed: dict[str, tuple[str | None, str | None]]) -> str:
    """A `result_changes` reason that names the stages whose identity changed (name: made -> planned), in the
    plan's order; `concerns` reads the names back."""
    return "its stages changed (" + ", ".join(f"{name}: {was} -> {now}" for name, (was, now) in changed.items()) + ")"


def _evaluated_stage(result: dict, name: str) -> str | None:
    """The stage whose run evaluation `name` of `result` loaded its checkpoint from, None when none is named."""
    checkpoint = Path(result.get("evals", {}).get(name, {}).get("checkpoint", ""))
    return next((stage for stage, run in result.get("stages", {}).items() if Path(run) in checkpoint.parents), None)


def concerns(reason: str, result: dict, name: str) -> bool:
    """Whether a `result_changes` reason about `result` concerns its evaluation `name`, so that a table marks that
    evaluation's cells: a changed evaluation concerns only itself; changed stages concern the evaluations of those
    stages and of every stage after them in the plan (trained on them), not a mid level evaluated alone whose high
    level alone changed; any other reason (the set of evaluations, the curve) the whole job."""
    evaluation = re.match(r"evaluation '([^']+)' ", reason)
    if evaluation:
        return evaluation.group(1) == name
    changed = re.match(r"its stages changed \((.*)\)$", reason)
    order, evaluated = list(result.get("stages", {})), _evaluated_stage(result, name)
    if not changed or evaluated is None:
        return True
    names = re.findall(r"(\w+): \S+ -> \S+", changed.group(1))
    return any(stage not in order or order.index(stage) <= order.index(evaluated) for stage in names)


def result_changes(result: dict, cfg: DictConfig, planned: list[PlannedStage], root: Path | None = None) -> str:
    """What makes a job's finished `result` stale against its experiment now, "" when nothing does: another stage
    identity (a budget, reward or tracker value changed), or other evaluations or curve than the experiment asks for.
    `root` holds the stage records (`stage.yaml`) of the result's stages: the sweep root, or the archive.
    """
    made = {name: stages.identity_of(Path(path)) for name, path in result.get("stages", {}).items()}
    wanted = {stage.name: stage.identity for stage in planned}
    same = _same_stages(result, cfg, planned, root)
    changed = [name for name in {**wanted, **made} if name not in same]  # the plan's order, then stages it lacks
    if changed:
        return _about_stages({name: (made.get(name), wanted.get(name)) for name in changed})
    evals = sorted(name for name, spec in cfg.experiment.evals.items() if applies(spec, cfg.method.name))
    if sorted(result.get("evals", {})) != evals:
        return f"its evaluations changed ({', '.join(sorted(result.get('evals', {})))} -> {', '.join(evals)})"
    for name in evals:  # results made before evaluations recorded their overrides are taken as they are
        recorded, now = result["evals"][name].get("overrides"), eval_overrides(cfg.experiment.evals[name])
        if recorded is not None and recorded != now:
            return _about_evaluation(name, f"changed ({' '.join(recorded) or 'as trained'} -> {' '.join(now)})")
        if _walker_changed(result["evals"][name], result, cfg, name, planned):
            if "lowlevel_policy" not in result["evals"][name]:
                return _about_evaluation(name, "recorded no locomotion policy")
            return _about_evaluation(name, "walked its robots with another locomotion policy than now")
    if bool(result.get("curve")) != bool(budget_of(cfg).get("curve")):
        return "its learning curve was added or dropped"
    return ""


def _curve(cfg: DictConfig, evaluated: Path) -> dict | None:
    """The budget's `curve`: the evaluated stage's checkpoints evaluated as the named evaluation, with the
    experiment's budget rule; None when the budget asks for none."""
    budget = budget_of(cfg)
    curve = budget.get("curve")
    if not curve:
        return None
    run_cfg = to_plain(apply_overrides(load_run_config(evaluated), eval_overrides(cfg.experiment.evals[curve.eval])))
    episodes, seeds = int(budget.eval.episodes), list(budget.eval.seeds)
    points = learning_curve(evaluated, run_cfg, float(curve.every_env_steps), episodes, seeds)
    rule = OmegaConf.to_container(cfg.experiment.budget_rule)
    return {**OmegaConf.to_container(curve), "rule": rule, "points": points}


def train_stage(stage_dir: Path, overrides: list[str], iterations: int, save_interval: int, threads: int) -> Path:
    """The finished run of one stage in its store dir: reused, resumed from its last checkpoint (with the job's
    `threads`, not those of the process it was cut in), or trained from scratch for `iterations`."""
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
    stages.write_identity(stage_dir, to_plain(cfg), stage_dir.name)
    return training.train(cfg, overrides, command=f"mapush sweep (stage of {stage_dir.parent})")


def eval_overrides(spec) -> list[str]:
    """The overrides of one of an experiment's evaluations: a list, or `{overrides: [...], methods: [...],
    stage: ...}` (methods: only theirs; stage: a trained stage other than the evaluated one, e.g. `mid`)."""
    return list(spec if OmegaConf.is_list(spec) else spec.get("overrides", []))


def applies(spec, method: str) -> bool:
    """Whether an experiment's evaluation is made for `method`'s jobs (a spec's `methods`, else every method)."""
    return OmegaConf.is_list(spec) or method in spec.get("methods", [method])


def eval_stage(cfg: DictConfig, spec) -> str:
    """The stage an evaluation runs: its own `stage`, or else the experiment's evaluated stage."""
    own = None if OmegaConf.is_list(spec) else spec.get("stage")
    return own or evaluated_stage(cfg)


def _resolve_stage_refs(override: str, runs: dict[str, Path]) -> str:
    key, sep, value = override.partition("=")
    if not sep or not value.startswith(STAGE_REF):
        return override
    stage = value[len(STAGE_REF) :]
    if stage not in runs:
        raise BadInput(f"override {override!r} refers to stage {stage!r}, not trained before it")
    return f"{key}={quoted(runs[stage])}"


def every_stage_override(overrides: list[str]) -> str:
    """A sweep job's `overrides` (extra overrides for every stage) as one Hydra override: `overrides=['a=1','b=2']`."""
    return "overrides=[" + ",".join(repr(o) for o in overrides) + "]"


def quoted(path: Path) -> str:
    """A path as a quoted Hydra override value (job dirs hold `=` and `,`)."""
    text = str(path)
    if "'" in text:
        raise BadInput(f"path {text!r} holds a single quote; valid: a sweep_root and overrides without quotes")
    return f"'{text}'"
