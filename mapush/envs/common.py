"""What the mid- and high-level envs share: config checks, reading the simulation, the exceptions every level has,
and the per-episode outcomes rsl-rl logs."""

from __future__ import annotations

import numpy as np
import torch

from mapush.envs.resets import check_agent_count
from mapush.errors import BadInput
from mapush.lowlevel import BACKENDS
from mapush.rewards.manager import RewardManager

BASE_EXCEPTIONS = ("diverged", "robot_collision", "object_tilt", "robot_tilt")
"""Exceptions of every level, in this order at the head of each env's `EXCEPTIONS` (paper III-C: r_exception)."""

RECENT_EPISODES = 500
"""Episodes in the rolling success rate that is logged every step (`Metrics/recent_success_rate`)."""


def validate_push_config(cfg: dict) -> None:
    """Check a config before anything is built or written: low-level backend, agent count, reward terms."""
    if cfg["lowlevel"]["name"] not in BACKENDS:
        raise BadInput(f"unknown lowlevel {cfg['lowlevel']['name']!r}; valid: {', '.join(BACKENDS)}")
    BACKENDS[cfg["lowlevel"]["name"]](cfg["lowlevel"])  # e.g. the go1 backend's policy must exist
    check_agent_count(cfg["task"], cfg["level"]["min_spawn_distance"])
    RewardManager(cfg["reward"]["terms"])


def read_sim_state(env) -> None:
    """Copy the simulation state into env attributes (`object_xy`, `robot_xy`, ...; see `BatchSim.read`), plus
    `robot_distance` (E, A, A) between robot centres (diagonal 0; torch.cdist is ~100x slower at this size)."""
    for name, value in env.sim.read().items():
        setattr(env, name, value)
    env.robot_distance = torch.linalg.vector_norm(env.robot_xy.unsqueeze(2) - env.robot_xy.unsqueeze(1), dim=-1)


def divergence(env, failed: np.ndarray) -> torch.Tensor:
    """(E,) envs whose simulation failed this step or whose state is no longer finite."""
    diverged = torch.zeros(env.num_envs, dtype=torch.bool)
    diverged[torch.from_numpy(failed)] = True
    return diverged | ~torch.isfinite(env.object_xy).all(-1) | ~torch.isfinite(env.robot_xy).flatten(1).all(-1)


def base_exception_flags(env, diverged: torch.Tensor) -> torch.Tensor:
    """(len(BASE_EXCEPTIONS), E) flags, in that order."""
    task, level = env.cfg["task"], env.cfg["level"]
    pair = env.robot_distance + torch.eye(env.num_agents) * 1e9
    return torch.stack(
        [
            diverged,
            (pair < task["collision_distance"]).flatten(1).any(-1),
            env.object_tilt > level["object_max_tilt"],
            (env.robot_tilt > level["robot_max_tilt"]).any(-1),
        ]
    )


def pose_frame(env) -> dict[str, torch.Tensor]:
    """The poses and subgoal every viewer draws, (E, ...) each (see `mapush.logging.scene`)."""
    return {
        "object_xy": env.object_xy,
        "object_z": env.object_z,
        "object_yaw": env.object_yaw,
        "robot_xy": env.robot_xy,
        "robot_yaw": env.robot_yaw,
        "subgoal_xy": env.subgoal_xy,
    }


def episode_end(env, done: torch.Tensor, diverged: torch.Tensor, failed: torch.Tensor) -> dict[str, torch.Tensor]:
    """Per-env outcomes of the episodes ending now (`done`), as every env reports them in `info["episode_end"]`.

    Args:
        failed: the envs whose episode ends as an exception (a failure).
    """
    return {
        "done": done.clone(),
        "success": env.success & done,
        "exception": failed & done,
        "diverged": diverged & done,
        "exception_kind": torch.where(done, env.exception_kind, -1),
        "time_s": env.episode_time_s,
    }


class EpisodeOutcomes:
    """A ring buffer of the latest episodes' successes, and the `info` an env step returns about finished ones."""

    def __init__(self):
        self.recent_success = torch.full((RECENT_EPISODES,), float("nan"))
        self._next = 0

    def info(self, end: dict[str, torch.Tensor], episode_sums: dict, extra: dict | None = None) -> dict:
        """`{"episode_end": end, "log": ...}`: the log means over the episodes that end now (`end["done"]`).

        Args:
            end: per-env outcomes with at least `done`, `success`, `exception` (masked by done) and `time_s`.
            episode_sums: reward term -> (E, rows) episode sums.
            extra: more per-env values (E,) to log as `Metrics/<name>` means over the finished episodes.
        """
        done = end["done"]
        if not done.any():
            return {"episode_end": end, "log": {"Metrics/recent_success_rate": self.recent_success.nanmean()}}
        outcomes = end["success"][done].float()[-RECENT_EPISODES:]
        slots = (self._next + torch.arange(len(outcomes))) % RECENT_EPISODES
        self.recent_success[slots] = outcomes
        self._next = int(slots[-1] + 1) % RECENT_EPISODES
        log = {f"Reward/{name}": sums[done].mean() for name, sums in episode_sums.items()}
        log["Metrics/success_rate"] = end["success"][done].float().mean()
        log["Metrics/exception_rate"] = end["exception"][done].float().mean()
        for name, values in (extra or {}).items():
            log[f"Metrics/{name}"] = values[done].float().mean()
        log["Metrics/episode_time_s"] = end["time_s"][done].mean()
        log["Metrics/recent_success_rate"] = self.recent_success.nanmean()
        return {"episode_end": end, "log": log}
