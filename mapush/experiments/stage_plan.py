"""What a sweep job trains: its stages in order with every override, each stage's budget in env-steps and
iterations, its identity, and the evaluations the experiment asks of it (`planned_stages`). Nothing is trained
here."""

from __future__ import annotations

import math
from typing import NamedTuple

from omegaconf import DictConfig, OmegaConf

from mapush.config import env_steps_per_iteration, group_file, group_options
from mapush.errors import BadInput
from mapush.experiments import stages

STAGE_BUDGET_KEYS = ("num_envs", "env_steps")
"""What a budget sets for each stage (and what a stage's `by_task` entry may set for one task)."""


def stages_with_overrides(cfg: DictConfig) -> list[tuple[str, list[str]]]:
    """The stages to train, up to the evaluated one, each with every override it is composed with.

    Order: the method's common overrides, the experiment's (`overrides`, where it has them), the stage's, the job's
    task / seed / agents / extra overrides, then the budget's num_envs (`planned_stages` turns the budget's
    env-steps into `train.iterations`).
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


def stage_curve_specs(cfg: DictConfig, trained: list[str] | set[str]) -> dict[str, dict]:
    """How the budget's `curve.stages` asks each stage among `trained`, other than the evaluated one, to have its
    own learning curve drawn: {stage: {every_env_steps, episodes, seeds}} (episodes by default the budget's)."""
    budget = budget_of(cfg)
    curve = budget.get("curve")
    asked = curve.get("stages", {}) if curve else {}
    return {
        name: {
            "every_env_steps": float(curve.every_env_steps),
            "episodes": int((asked[name] or {}).get("episodes", budget.eval.episodes)),
            "seeds": [int(s) for s in budget.eval.seeds],
        }
        for name in asked
        if name in trained and name != evaluated_stage(cfg)
    }


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
    for name, overrides in stages_with_overrides(cfg):
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


def iterations_for(stage_cfg: DictConfig | dict, env_steps: float) -> int:
    """PPO iterations that give at least `env_steps` 50 Hz control steps."""
    return max(1, math.ceil(float(env_steps) / env_steps_per_iteration(stage_cfg)))


def eval_overrides(cfg: DictConfig, name: str) -> list[str]:
    """The overrides of the experiment's evaluation `name`: its own, then the budget's `eval.overrides`, which every
    evaluation of that budget takes (the OCB ablation's smoke budget: 1 s episodes). An evaluation is a list of
    overrides, or `{overrides: [...], methods: [...], stage: ...}` (methods: only theirs; stage: a trained stage
    other than the evaluated one, e.g. `mid`)."""
    spec = cfg.experiment.evals[name]
    own = spec if OmegaConf.is_list(spec) else spec.get("overrides", [])
    return [*own, *budget_of(cfg).eval.get("overrides", [])]


def applies(spec, method: str) -> bool:
    """Whether an experiment's evaluation is made for `method`'s jobs (a spec's `methods`, else every method)."""
    return OmegaConf.is_list(spec) or method in spec.get("methods", [method])


def eval_stage(cfg: DictConfig, spec) -> str:
    """The stage an evaluation runs: its own `stage`, or else the experiment's evaluated stage."""
    own = None if OmegaConf.is_list(spec) else spec.get("stage")
    return own or evaluated_stage(cfg)


def experiment_axis(table: str | None, axis: str) -> list:
    """The values of the sweep axis `axis` (`agents`, `task`, ...) of the experiments whose jobs fill `table` (every
    experiment's when None), in the order their files give them; [] where none sweeps it."""
    values = []
    for name in group_options("experiment"):
        spec = group_file("experiment", name)
        if table is None or spec.get("table") == table:
            values += [v for v in (spec.get("sweep") or {}).get(axis) or [] if v not in values]
    return values


def experiment_evals(table: str | None) -> list[str]:
    """The evaluations the experiments whose jobs fill `table` make (every experiment's when None), read from their
    files as written: each one's `evals` and those its Hydra defaults take in (`- /ladder@evals: rungs`)."""
    names = set()
    for name in group_options("experiment"):
        spec = group_file("experiment", name)
        if table is not None and spec.get("table") != table:
            continue
        names |= set(spec.get("evals") or {})
        for entry in spec.get("defaults") or []:
            for target, option in entry.items() if hasattr(entry, "items") else []:
                group, _, package = str(target).lstrip("/").partition("@")
                if package == "evals":
                    names |= set(group_file(group, option))
    return sorted(names)
