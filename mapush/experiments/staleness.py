"""Whether a job's finished `result.json` still stands for what its experiment plans now: the same stages, the
same evaluations, the same locomotion policy walking its legged evaluations (`result_changes`, `still_valid`).
What it finds is a `Change` (`results.py`), which says which of a result's evaluations it concerns."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.experiments import stages
from mapush.experiments.job_records import Curve, CurveRule, Evaluation
from mapush.experiments.results import Change, JobResult
from mapush.experiments.stage_plan import PlannedStage, applies, budget_of, eval_overrides, eval_stage, evaluated_stage
from mapush.lowlevel import backend_of


def still_valid(
    result: JobResult, cfg: DictConfig, planned: list[PlannedStage], root: Path | None = None
) -> tuple[dict[str, Evaluation], Curve | None]:
    """Of an earlier `result`, the evaluations (and the learning curve) that hold under the experiment now: made of
    a stage with the same identity (or one it was adopted from), with the same overrides and locomotion policy.
    An evaluation that recorded no overrides (made before they were recorded) is taken as made with today's, as
    `result_changes` takes it. `root` holds the stage records, by default the sweep root (`result_changes`)."""
    same = same_stages(result, cfg, planned, root)
    kept = {}
    for name, spec in cfg.experiment.evals.items():
        record, overrides = result.evals.get(name), eval_overrides(cfg, name)
        holds = record and applies(spec, cfg.method.name) and eval_stage(cfg, spec) in same
        holds = holds and (overrides if record.overrides is None else record.overrides) == overrides
        holds = holds and not swapped_rules_unfixed(record)
        if holds and not _walker_changed(record, result, cfg, name, planned):
            kept[name] = dataclasses.replace(record, overrides=list(overrides))
    curve, spec = result.curve, budget_of(cfg).get("curve")
    holds = curve and spec and evaluated_stage(cfg) in same and curve.eval in kept
    if not holds or curve.every_env_steps != spec.every_env_steps:
        return kept, None
    rule = CurveRule(**OmegaConf.to_container(cfg.experiment.budget_rule))
    return kept, dataclasses.replace(curve, rule=rule)  # judged by today's rule


def drawn_alike(curve: Curve | dict | None, spec: dict) -> bool:
    """Whether a recorded stage curve (or one written into a stage's run dir, as a record) was drawn at the marks,
    episodes and seeds `spec` asks for (`stage_plan.stage_curve_specs`)."""
    record = curve.record() if isinstance(curve, Curve) else curve
    return bool(record) and {key: record.get(key) for key in spec} == spec


def _walker_changed(
    record: Evaluation, result: JobResult, cfg: DictConfig, name: str, planned: list[PlannedStage]
) -> bool:
    """Whether the locomotion policy evaluation `name` would walk its robots with now (`lowlevel.policy`, or the
    shipped one) is another than the one its `record` names; a legged evaluation that named none counts as
    changed. The stage's run config says which policy, or where the run is gone (another machine, an archived
    job), the stage's config as the experiment plans it now."""
    spec = cfg.experiment.evals[name]
    stage = eval_stage(cfg, spec)
    run = result.stages.get(stage)
    if run and Path(run).is_dir():
        stage_cfg = load_run_config(run)
    else:
        stage_cfg = OmegaConf.create(next(p.cfg for p in planned if p.name == stage))
    lowlevel = to_plain(apply_overrides(stage_cfg, eval_overrides(cfg, name)))["lowlevel"]
    now = backend_of(lowlevel).policy_fingerprint(lowlevel)
    # the policy's hash says which it is; its file's path moves with the checkout
    return (now or {}).get("sha256") != (record.lowlevel_policy or {}).get("sha256")


def same_stages(result: JobResult, cfg: DictConfig, planned: list[PlannedStage], root: Path | None = None) -> set[str]:
    """Names of the planned stages that `result` was made with: the same identity, or one the planned stage was
    adopted from (`stages.stands_for`, read from the store under `root`, by default the sweep root)."""
    made = {name: stages.identity_of(Path(path)) for name, path in result.stages.items()}
    root = Path(cfg.sweep_root if root is None else root)
    return {s.name for s in planned if made.get(s.name) in stages.stands_for(root, s.identity)}


def swapped_rules_unfixed(record: Evaluation) -> bool:
    """Whether an evaluation swapped its stage's rules (`rules=...` among its recorded overrides) before a swap
    took every ending from the new rule set (`config.overrides`, 2026-12-07): until then `rules=strict` on a stage
    trained under the original's kept the original's endings. Its record, made before evaluations recorded their
    composed config (`config_sha256`), is stale."""
    return any(o.startswith("rules=") for o in record.overrides or []) and "config_sha256" not in record.also


def _about_evaluation(name: str, what: str) -> Change:
    """A change that concerns one evaluation only."""
    return Change("evaluation", f"evaluation {name!r} {what}", evaluation=name)


def _about_stages(changed: dict[str, tuple[str | None, str | None]]) -> Change:
    """A change of the stages whose identity changed (name: made -> planned), in the plan's order."""
    text = ", ".join(f"{name}: {was} -> {now}" for name, (was, now) in changed.items())
    return Change("stages", f"its stages changed ({text})", stages=tuple(changed))


def result_changes(
    result: JobResult, cfg: DictConfig, planned: list[PlannedStage], root: Path | None = None
) -> Change | None:
    """What makes a job's finished `result` stale against its experiment now, None when nothing does: another stage
    identity (a budget, reward or tracker value changed), or other evaluations or curve than the experiment asks for.
    `root` holds the stage records (`stage.yaml`) of the result's stages: the sweep root, or the archive.
    """
    made = {name: stages.identity_of(Path(path)) for name, path in result.stages.items()}
    wanted = {stage.name: stage.identity for stage in planned}
    same = same_stages(result, cfg, planned, root)
    changed = [name for name in {**wanted, **made} if name not in same]  # the plan's order, then stages it lacks
    if changed:
        return _about_stages({name: (made.get(name), wanted.get(name)) for name in changed})
    evals = sorted(name for name, spec in cfg.experiment.evals.items() if applies(spec, cfg.method.name))
    if sorted(result.evals) != evals:
        had = ", ".join(sorted(result.evals))
        return Change("evaluations", f"its evaluations changed ({had} -> {', '.join(evals)})")
    for name in evals:  # results made before evaluations recorded their overrides are taken as they are
        recorded, now = result.evals[name].overrides, eval_overrides(cfg, name)
        if recorded is not None and recorded != now:
            return _about_evaluation(name, f"changed ({' '.join(recorded) or 'as trained'} -> {' '.join(now)})")
        if swapped_rules_unfixed(result.evals[name]):
            return _about_evaluation(name, "swapped its rules before a swap took the new set's endings (2026-12-07)")
        if _walker_changed(result.evals[name], result, cfg, name, planned):
            if result.evals[name].lowlevel_policy is None:
                return _about_evaluation(name, "recorded no locomotion policy")
            return _about_evaluation(name, "walked its robots with another locomotion policy than now")
    if bool(result.curve) != bool(budget_of(cfg).get("curve")):
        return Change("curve", "its learning curve was added or dropped")
    return None
