"""Learning curves: a run's checkpoints evaluated as `mapush eval` does, and what can be read off them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mapush.config import env_steps_per_iteration
from mapush.eval.rollout import evaluate_quietly
from mapush.rundir import checkpoint_iteration, checkpoints


def env_steps_at(cfg: dict, iteration: int) -> int:
    """50 Hz env-steps trained after `iteration` (0-based) of a run of `cfg`."""
    return (iteration + 1) * env_steps_per_iteration(cfg)


def last_before_marks(values: list[float], every: float) -> list[int]:
    """Indices of the last of the increasing `values` at or before every multiple of `every`, each once."""
    chosen: list[int] = []
    for mark in np.arange(every, values[-1] + every, every) if values else []:
        before = [k for k, v in enumerate(values) if v <= mark + 1e-6]
        if before and before[-1] not in chosen:
            chosen.append(before[-1])
    return chosen


def curve_checkpoints(run_dir: Path, cfg: dict, every_env_steps: float) -> list[Path]:
    """The last checkpoint at or before every multiple of `every_env_steps`, and the run's last one: of those the run
    kept (sweeps keep all; `algo.keep_checkpoints`)."""
    found = checkpoints(run_dir)
    chosen = last_before_marks([env_steps_at(cfg, checkpoint_iteration(p)) for p in found], every_env_steps)
    if found and len(found) - 1 not in chosen:
        chosen.append(len(found) - 1)
    return [found[k] for k in chosen]


def evaluate_points(cfg: dict, checkpoints_: list[Path], episodes: int, seeds: list[int]) -> list[dict]:
    """Evaluated success and completion time of each checkpoint under `cfg`, with its iteration and env-steps."""
    points = []
    for checkpoint in checkpoints_:
        summary = evaluate_quietly(cfg, checkpoint, episodes, seeds)
        iteration = checkpoint_iteration(checkpoint)
        points.append({
            "iteration": iteration,
            "env_steps": env_steps_at(cfg, iteration),
            "success_rate": summary["success_rate"],
            "success_rate_std": summary["success_rate_std"],
            "completion_time": summary["completion_time"],
        })  # fmt: skip
    return points


def learning_curve(
    run_dir: Path, cfg: dict, every_env_steps: float, episodes: int, seeds: list[int], drawn: list[dict] = ()
) -> list[dict]:
    """Evaluated success and completion time of the run's checkpoints (`curve_checkpoints`), under `cfg`. `drawn`:
    points evaluated alike before (a run since trained on): those at a checkpoint the curve still takes are kept,
    not evaluated again."""
    kept = {point["iteration"]: point for point in drawn}
    wanted = curve_checkpoints(run_dir, cfg, every_env_steps)
    new = evaluate_points(cfg, [c for c in wanted if checkpoint_iteration(c) not in kept], episodes, seeds)
    return sorted([kept[i] for i in map(checkpoint_iteration, wanted) if i in kept] + new, key=lambda p: p["iteration"])
