"""The mid-level pushing env: robots push the object to a nearby subgoal (paper III-C, App. A).

Vectorized over envs E and agents A; no Python loop over either in a step. The step skeleton, observations and
exceptions come from the env core (`mapush.envs.base`); this level supplies its start layouts, the subgoal
distance, success and the step's commands. Observation and exception terms: `conf/level/mid.yaml`.
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.envs.pushing import PushEnv
from mapush.envs.resets import sample_mid_layout


def commands_from_actions(actions: torch.Tensor, gain: float, scale: torch.Tensor) -> torch.Tensor:
    """Velocity commands (..., 3) from raw mid-level actions (..., 3): `gain` x action, clipped to [-1, 1], times
    `scale` (`level.action_gain`, `level.action_scale`). At gain 0.5 a command saturates only at a raw output of 2,
    as in the original's chain."""
    return (gain * actions).clamp(-1.0, 1.0) * scale


class MidPushEnv(PushEnv):
    """E envs x A robots pushing one object each toward a subgoal 1.5-3 m away; one policy row per robot.

    Args:
        cfg: the composed config as a plain dict (task, level, lowlevel, reward, sim, seed).
        num_envs: overrides `cfg["num_envs"]` (eval and bench use their own counts).
        evaluation: an evaluation env (`PushEnv`: no drawn robot dynamics).
    """

    def __init__(self, cfg: dict, num_envs: int | None = None, evaluation: bool = False):
        super().__init__(cfg, num_envs, rows=cfg["task"]["num_agents"], evaluation=evaluation)
        self.action_scale = torch.tensor(cfg["level"]["action_scale"], dtype=torch.float32)
        self.action_gain = float(cfg["level"]["action_gain"])
        self.num_actions = len(self.action_scale)  # (vx, vy, yaw rate)
        self.subgoal_distance = torch.zeros(self.num_envs)
        self.prev_subgoal_distance = torch.zeros(self.num_envs)  # set by reset(), then after every step's rewards
        self.reset(np.arange(self.num_envs))

    def _sample_layout(self, n: int) -> dict[str, torch.Tensor]:
        """Start layouts of `n` episodes (`sample_mid_layout`'s keys)."""
        return sample_mid_layout(self.generator, n, self.cfg["task"], self.cfg["level"]["min_spawn_distance"])

    def _start_episodes(self, ids: np.ndarray, t: torch.Tensor) -> None:
        layout = self._sample_layout(len(ids))
        self.sim.reset(ids, layout)
        self.subgoal_xy[t] = layout["subgoal_xy"]

    def _read_state(self) -> None:
        """The simulation state, plus the object-subgoal distance."""
        super()._read_state()
        self.subgoal_distance = torch.linalg.vector_norm(self.state.object_xy - self.subgoal_xy, dim=-1)

    def _started(self, t: torch.Tensor) -> None:
        self.prev_subgoal_distance[t] = self.subgoal_distance[t]

    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """Advance every env by one policy step.

        Args:
            actions: raw policy outputs, (E, A, 3); turned into (vx, vy, yaw rate) by `commands_from_actions`.

        Returns:
            obs (after resets), rewards (E, A), terminated (E,) success or exception, truncated (E,) timeout,
            info with `log` (means over the episodes that ended this step) and `episode_end` per-env outcomes.
        """
        commands = commands_from_actions(actions, self.action_gain, self.action_scale)
        failed = self._advance(commands)
        self.episode_step += 1
        self.diverged = self._divergence(failed)
        flags = self.exception_flags()
        self.exception = flags.any(0)
        self.exception_kind = self.first_exception(flags)
        self.success = (self.subgoal_distance < self.cfg["level"]["success_distance"]) & ~self.exception
        terminated = self.success | self.exception
        truncated = (self.episode_step >= self.max_episode_length) & ~terminated
        reward, parts = self.rewards.compute(self)
        self.prev_subgoal_distance = self.subgoal_distance.clone()
        return self._finish_step(reward, parts, terminated, truncated, commands)
