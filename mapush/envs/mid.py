"""The mid-level pushing env: robots push the object to a nearby subgoal (paper III-C, App. A).

Vectorized over envs E and agents A; no Python loop over either in a step. One step (architecture section 3):
commands -> physics -> state -> terminations -> rewards (before any reset) -> reset finished envs -> observations.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from mapush.envs import observations as obs_terms
from mapush.envs.resets import check_agent_count, sample_mid_layout
from mapush.errors import BadInput
from mapush.lowlevel import BACKENDS
from mapush.rewards.manager import RewardManager
from mapush.sim.core import BatchSim
from mapush.sim.shapes import object_hull

EXCEPTIONS = ("diverged", "robot_collision", "object_tilt", "robot_tilt")
"""Named exceptions (paper III-C: r_exception); `exception_kind` indexes this tuple, the first that fired wins."""

RECENT_EPISODES = 500
"""Episodes in the rolling success rate that is logged every step (`Metrics/recent_success_rate`)."""


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
        self.sim = BatchSim(cfg["sim"], task, self.lowlevel, self.num_envs)
        self.rewards = RewardManager(cfg["reward"]["terms"])
        self.dt = self.sim.dt
        self.frame_dt = self.dt  # interval between recorder captures
        # the tolerance keeps 0.14 s / 0.02 s = 7.000000000000001 at 7 steps
        self.max_episode_length = math.ceil(level["episode_length_s"] / self.dt - 1e-9)
        self.action_scale = torch.tensor(level["action_scale"], dtype=torch.float32)
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
        self.recent_success = torch.full((RECENT_EPISODES,), float("nan"))  # ring buffer of the latest outcomes
        self._recent_next = 0
        self.reset(np.arange(E))

    @staticmethod
    def validate(cfg: dict) -> None:
        """Check a config before anything is built or written: agent count, reward terms, low-level backend."""
        if cfg["lowlevel"]["name"] not in BACKENDS:
            raise BadInput(f"unknown lowlevel {cfg['lowlevel']['name']!r}; valid: {', '.join(BACKENDS)}")
        check_agent_count(cfg["task"], cfg["level"]["min_spawn_distance"])
        RewardManager(cfg["reward"]["terms"])

    # ----------------------------------------------------------------------------------------------------------
    def reset(self, ids: np.ndarray) -> None:
        """Start new episodes in envs `ids`: sample a layout, write it to the simulation, refresh the state."""
        if len(ids) == 0:
            return
        layout = sample_mid_layout(self.generator, len(ids), self.cfg["task"], self.cfg["level"]["min_spawn_distance"])
        self.sim.reset(ids, layout)
        t = torch.from_numpy(ids)
        self.subgoal_xy[t] = layout["subgoal_xy"]
        self.episode_step[t] = 0
        for sums in self.episode_sums.values():
            sums[t] = 0.0
        self._read_state()
        self.prev_subgoal_distance[t] = self.subgoal_distance[t]

    def _read_state(self) -> None:
        """Copy the simulation state into env attributes (`object_xy`, `robot_xy`, ...; see `BatchSim.read`)."""
        for name, value in self.sim.read().items():
            setattr(self, name, value)
        self.subgoal_distance = torch.linalg.vector_norm(self.object_xy - self.subgoal_xy, dim=-1)
        # (E, A, A) distances between robot centres; the diagonal is 0 (torch.cdist is ~100x slower at this size)
        self.robot_distance = torch.linalg.vector_norm(self.robot_xy.unsqueeze(2) - self.robot_xy.unsqueeze(1), dim=-1)

    @property
    def episode_time_s(self) -> torch.Tensor:
        """Simulated time of each env's episode, s."""
        return self.episode_step.float() * self.dt

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets): poses (E, ...) and the subgoal (E, 2)."""
        return {
            "object_xy": self.object_xy,
            "object_z": self.object_z,
            "object_yaw": self.object_yaw,
            "robot_xy": self.robot_xy,
            "robot_yaw": self.robot_yaw,
            "subgoal_xy": self.subgoal_xy,
        }

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

        level, task = self.cfg["level"], self.cfg["task"]
        self.success = self.subgoal_distance < level["success_distance"]
        diverged = torch.zeros(self.num_envs, dtype=torch.bool)
        diverged[torch.from_numpy(failed)] = True
        diverged |= ~torch.isfinite(self.object_xy).all(-1) | ~torch.isfinite(self.robot_xy).flatten(1).all(-1)
        pair = self.robot_distance + torch.eye(self.num_agents) * 1e9
        exceptions = torch.stack(
            [
                diverged,
                (pair < task["collision_distance"]).flatten(1).any(-1),
                self.object_tilt > level["object_max_tilt"],
                (self.robot_tilt > level["robot_max_tilt"]).any(-1),
            ]
        )  # (kinds, E) in the order of EXCEPTIONS
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
        end = {
            "done": done.clone(),
            "success": self.success & done,
            "exception": self.exception & done,
            "diverged": diverged & done,
            "exception_kind": torch.where(done, self.exception_kind, -1),
            "time_s": self.episode_step.float() * self.dt,
        }
        if not done.any():
            return {"episode_end": end, "log": {"Metrics/recent_success_rate": self.recent_success.nanmean()}}
        outcomes = self.success[done].float()[-RECENT_EPISODES:]
        slots = (self._recent_next + torch.arange(len(outcomes))) % RECENT_EPISODES
        self.recent_success[slots] = outcomes
        self._recent_next = int(slots[-1] + 1) % RECENT_EPISODES
        log = {f"Reward/{name}": sums[done].mean() for name, sums in self.episode_sums.items()}
        log["Metrics/success_rate"] = self.success[done].float().mean()
        log["Metrics/exception_rate"] = self.exception[done].float().mean()
        log["Metrics/episode_time_s"] = end["time_s"][done].mean()
        log["Metrics/recent_success_rate"] = self.recent_success.nanmean()
        return {"episode_end": end, "log": log}
