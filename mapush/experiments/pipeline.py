"""One sweep job: train a method's stages in order, evaluate the experiment's stage, write `result.json`.

A job dir holds one run dir per stage (`<job>/<stage>/<level>/<task>/<time>__seed<seed>`) and, once every
evaluation is done, `result.json`. Re-running a job skips it when `result.json` exists, skips stages whose run is
finished (it has the exported policy), resumes a stage cut after a checkpoint, and restarts one cut before.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import shutil
from pathlib import Path

import torch
from omegaconf import DictConfig, OmegaConf

from mapush.config import compose_config, load_run_config
from mapush.errors import BadInput
from mapush.rl.runner import POLICY_FILE, checkpoints

RESULT = "result.json"
STAGE_REF = "@"
"""An override value `@STAGE` (e.g. `mid=@mid`) stands for that earlier stage's run dir."""


def stage_plan(cfg: DictConfig) -> list[tuple[str, list[str]]]:
    """The stages to train, up to the evaluated one, each with every override it is composed with.

    Order: the method's common overrides, the stage's, the job's task / seed / agents / extra overrides, then the
    budget's num_envs (env-steps become `train.iterations` in `train_stage`).
    """
    method, experiment = cfg.method, cfg.experiment
    names = list(method.stages)
    evaluated = evaluated_stage(cfg)
    if evaluated not in names:
        raise BadInput(
            f"experiment {experiment.name!r} evaluates stage {evaluated!r}, which method "
            f"{method.name!r} lacks; valid stages: {', '.join(names)}"
        )
    budget = budget_of(cfg)
    job = [f"task={cfg.task.name}", f"seed={cfg.seed}"]
    if cfg.agents is not None:
        job.append(f"task.num_agents={cfg.agents}")
    plan = []
    for name in names[: names.index(evaluated) + 1]:
        if name not in budget.stages:
            raise BadInput(f"budget {cfg.budget!r} of experiment {experiment.name!r} has no stage {name!r}")
        overrides = [*method.overrides, *method.stages[name], *job, *cfg.overrides]
        overrides.append(f"num_envs={budget.stages[name].num_envs}")
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


def variant(cfg: DictConfig) -> str:
    """The sweep's name without its experiment prefix (e.g. `quick`, `smoke_debug-smoke`): one table per variant."""
    name, prefix = str(cfg.sweep_name), f"{cfg.experiment.name}_"
    return name[len(prefix) :] if name.startswith(prefix) else name


def iterations_for(stage_cfg: DictConfig | dict, env_steps: float) -> int:
    """PPO iterations that give at least `env_steps` 50 Hz control steps (a high-level decision holds several)."""
    per_decision = int(stage_cfg["level"].get("decision_steps", 1))
    per_iteration = int(stage_cfg["num_envs"]) * int(stage_cfg["algo"]["num_steps_per_env"]) * per_decision
    return max(1, math.ceil(float(env_steps) / per_iteration))


def run_job(cfg: DictConfig, job_dir: Path, threads: int) -> dict:
    """Train, evaluate and record one job; returns the result (also written to `job_dir/result.json`)."""
    from mapush.eval.rollout import evaluate

    job_dir = Path(job_dir)
    done = job_dir / RESULT
    if done.is_file():
        return json.loads(done.read_text())
    torch.set_num_threads(threads)
    budget = budget_of(cfg)
    runs: dict[str, Path] = {}
    for name, overrides in stage_plan(cfg):
        overrides = [_resolve_stage_refs(o, runs) for o in overrides] + [f"sim.nthread={threads}"]
        runs[name] = train_stage(job_dir / name, overrides, float(budget.stages[name].env_steps))
    evaluated = runs[evaluated_stage(cfg)]
    evals = {}
    for name, overrides in cfg.experiment.evals.items():
        path = evaluate(evaluated, int(budget.eval.episodes), list(budget.eval.seeds), list(overrides), name=name)
        evals[name] = {k: v for k, v in json.loads(path.read_text()).items() if k != "per_seed"}
        evals[name]["file"] = str(path)
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
        "stages": {name: str(path) for name, path in runs.items()},
        "evals": evals,
        "finished": datetime.datetime.now().isoformat(timespec="seconds"),
    }
    tmp = done.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2) + "\n")
    os.replace(tmp, done)
    return result


def train_stage(stage_dir: Path, overrides: list[str], env_steps: float) -> Path:
    """The finished run of one stage: reused, resumed from its last checkpoint, or trained from scratch."""
    from mapush import train as training

    for run_dir in sorted(p.parent for p in stage_dir.glob("**/config.yaml")):
        if (run_dir / POLICY_FILE).is_file():
            return run_dir
        if training.is_complete(run_dir):
            return training.export_finished(run_dir)
        if checkpoints(run_dir):
            return training.resume(run_dir, None)
        shutil.rmtree(run_dir)  # cut before its first checkpoint: nothing to keep
    cfg = compose_config(overrides)
    budget = {
        "train.iterations": iterations_for(cfg, env_steps),
        "train.run_root": str(stage_dir),
        "train.progress": False,
    }
    for key, value in budget.items():
        OmegaConf.update(cfg, key, value)
    overrides = [*overrides, *(f"{key}={value}" for key, value in budget.items())]  # the run's record
    return training.train(cfg, overrides, command=f"mapush sweep (stage of {stage_dir.parent})")


def _resolve_stage_refs(override: str, runs: dict[str, Path]) -> str:
    key, sep, value = override.partition("=")
    if not sep or not value.startswith(STAGE_REF):
        return override
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
