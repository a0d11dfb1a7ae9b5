"""The mid-level pushing env: robots push the object to a nearby subgoal (paper III-C, App. A).

Vectorized over envs E and agents A; no Python loop over either in a step. One step (architecture section 3):
commands -> physics -> state -> terminations -> rewards (before any reset) -> reset finished envs -> observations.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from mapush.envs import observations as obs_terms
from mapush.envs.common import (
    BASE_EXCEPTIONS,
    EpisodeOutcomes,
    base_exception_flags,
    divergence,
    episode_end,
    pose_frame,
    read_sim_state,
    validate_push_config,
)
from mapush.envs.resets import sample_mid_layout
from mapush.logging.scene import SceneLayout
from mapush.lowlevel import BACKENDS
from mapush.rewards.manager import RewardManager
from mapush.sim.core import BatchSim
from mapush.sim.shapes import object_hull

EXCEPTIONS = BASE_EXCEPTIONS
"""Named exceptions (paper III-C: r_exception); `exception_kind` indexes this tuple, the first that fired wins."""


class MidPushEnv:
    """E envs x A robots pushing one object each toward a subgoal 1.5-3 m away.

    `EXCEPTIONS` names the exception kinds (`exception_kind` indexes it).

    Args:
        cfg: the composed config as a plain dict (task, level, lowlevel, reward, sim, seed).
        num_envs: overrides `cfg["num_envs"]` (eval and bench use their own counts).
    """

    EXCEPTIONS = EXCEPTIONS

    def __init__(self, cfg: dict, num_envs: int | None = None):
        self.validate(cfg)
        self.cfg = cfg
        task, level = cfg["task"], cfg["level"]
        self.num_envs = num_envs or cfg["num_envs"]
        self.num_agents = task["num_agents"]
        self.policy_agents = self.num_agents  # one policy row per robot (decentralized, shared weights)
        self.lowlevel = BACKENDS[cfg["lowlevel"]["name"]](cfg["lowlevel"])
        self.sim = self._make_sim()
        self.rewards = RewardManager(cfg["reward"]["terms"])
        self.dt = self.sim.dt
        self.frame_dt = self.dt  # interval between recorder captures
        # the tolerance keeps 0.14 s / 0.02 s = 7.000000000000001 at 7 steps
        self.max_episode_length = math.ceil(level["episode_length_s"] / self.dt - 1e-9)
        self.action_scale = torch.tensor(level["action_scale"], dtype=torch.float32)
        self.num_actions = len(self.action_scale)  # (vx, vy, yaw rate)
        self.hull = torch.tensor(object_hull(task["object"]), dtype=torch.float32)
        A = self.num_agents
        self.other_agents = (torch.arange(A).unsqueeze(1) + torch.arange(1, A).unsqueeze(0)) % A  # (A, A-1)
        self.agent_one_hot = torch.eye(A).unsqueeze(0)  # (1, A, A)
        self.generator = torch.Generator().manual_seed(int(cfg["seed"]))
        E = self.num_envs
        self.episode_step = torch.zeros(E, dtype=torch.long)
        self.subgoal_xy = torch.zeros(E, 2)
        self.prev_subgoal_distance = torch.zeros(E)  # set by reset(), then after every step's rewards
        self.success = torch.zeros(E, dtype=torch.bool)
        self.exception = torch.zeros(E, dtype=torch.bool)
        self.exception_kind = torch.full((E,), -1)
        self.recorders = []  # EpisodeRecorder / LiveView (mapush.logging.episodes) watching some envs
        self.episode_sums = {name: torch.zeros(E, A) for name in self.rewards.terms}
        self.outcomes = EpisodeOutcomes()
        self.reset(np.arange(E))

    validate = staticmethod(validate_push_config)

    def _make_sim(self) -> BatchSim:
        """The batched simulation: free space (the long-horizon variant adds obstacle blocks)."""
        return BatchSim(self.cfg["sim"], self.cfg["task"], self.lowlevel, self.num_envs)

    def _sample_layout(self, n: int) -> dict[str, torch.Tensor]:
        """Start layouts of `n` episodes (`sample_mid_layout`'s keys)."""
        return sample_mid_layout(self.generator, n, self.cfg["task"], self.cfg["level"]["min_spawn_distance"])

    # ----------------------------------------------------------------------------------------------------------
    def reset(self, ids: np.ndarray) -> None:
        """Start new episodes in envs `ids`: sample a layout, write it to the simulation, refresh the state."""
        if len(ids) == 0:
            return
        layout = self._sample_layout(len(ids))
        self.sim.reset(ids, layout)
        t = torch.from_numpy(ids)
        self.subgoal_xy[t] = layout["subgoal_xy"]
        self.episode_step[t] = 0
        for sums in self.episode_sums.values():
            sums[t] = 0.0
        self._read_state()
        self.prev_subgoal_distance[t] = self.subgoal_distance[t]

    def _read_state(self) -> None:
        """The simulation state as env attributes (`read_sim_state`), plus the object-subgoal distance."""
        read_sim_state(self)
        self.subgoal_distance = torch.linalg.vector_norm(self.object_xy - self.subgoal_xy, dim=-1)

    @property
    def episode_time_s(self) -> torch.Tensor:
        """Simulated time of each env's episode, s."""
        return self.episode_step.float() * self.dt

    @staticmethod
    def scene_layout(cfg: dict) -> SceneLayout:
        """What the episode logs draw of this level (the arena, object and robots of `cfg`)."""
        return SceneLayout.from_config(cfg)

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets): poses (E, ...) and the subgoal (E, 2)."""
        return pose_frame(self)

    # ----------------------------------------------------------------------------------------------------------
    def observations(self) -> dict[str, torch.Tensor]:
        """`policy`: (E, A, local dim) and `critic`: (E, A, global dim), NaN-free."""
        return {
            "policy": torch.nan_to_num(obs_terms.local_observation(self), 0.0, 0.0, 0.0),
            "critic": torch.nan_to_num(obs_terms.global_observation(self), 0.0, 0.0, 0.0),
        }

    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """Advance every env by one policy step.

        Args:
            actions: raw policy outputs, (E, A, 3); clipped to [-1, 1] and scaled to (vx, vy, yaw rate).

        Returns:
            obs (after resets), rewards (E, A), terminated (E,) success or exception, truncated (E,) timeout,
            info with `log` (means over the episodes that ended this step) and `episode_end` per-env outcomes.
        """
        commands = actions.clamp(-1.0, 1.0) * self.action_scale
        failed = self.sim.step(commands)
        self._read_state()
        self.episode_step += 1

        self.success = self.subgoal_distance < self.cfg["level"]["success_distance"]
        diverged = divergence(self, failed)
        exceptions = base_exception_flags(self, diverged)  # (kinds, E) in the order of EXCEPTIONS
        self.exception = exceptions.any(0)
        self.exception_kind = torch.where(self.exception, exceptions.int().argmax(0), -1)
        self.success &= ~self.exception
        terminated = self.success | self.exception
        truncated = (self.episode_step >= self.max_episode_length) & ~terminated

        reward, parts = self.rewards.compute(self)
        reward = torch.nan_to_num(reward, 0.0, 0.0, 0.0)
        for name, value in parts.items():
            self.episode_sums[name] += torch.nan_to_num(value, 0.0, 0.0, 0.0)
        self.prev_subgoal_distance = self.subgoal_distance.clone()

        done = terminated | truncated
        for recorder in self.recorders:
            recorder.capture(self, commands, reward, parts, done)
        info = self._episode_info(done, diverged)
        self.reset(done.nonzero().flatten().numpy())
        return self.observations(), reward, terminated, truncated, info

    def _episode_info(self, done: torch.Tensor, diverged: torch.Tensor) -> dict:
        """Outcomes of the episodes ending now: per-env `episode_end` and the `log` means rsl-rl records."""
        return self.outcomes.info(episode_end(self, done, diverged, self.exception), self.episode_sums)
