"""Presents E envs x A agents to rsl-rl as E*A rows (MAPPO with parameter sharing).

Row r holds agent r % A of env r // A (row = env * A + agent). Every row of an env shares its done and time-out
flags; each row gets its own agent's reward.
"""

from __future__ import annotations

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from mapush.logging.metrics import PART_WAY_DONE


def to_rows(x: torch.Tensor) -> torch.Tensor:
    """(E, A, ...) -> (E*A, ...), row = env * A + agent."""
    return x.reshape(x.shape[0] * x.shape[1], *x.shape[2:])


def from_rows(x: torch.Tensor, rows_per_env: int) -> torch.Tensor:
    """(E*A, ...) -> (E, A, ...); the inverse of `to_rows`."""
    return x.reshape(x.shape[0] // rows_per_env, rows_per_env, *x.shape[1:])


def env_flags_to_rows(flags: torch.Tensor, rows_per_env: int) -> torch.Tensor:
    """A per-env flag (E,) repeated for each of its agents: (E*A,)."""
    return flags.repeat_interleave(rows_per_env)


class AgentRowsVecEnv(VecEnv):
    """rsl-rl VecEnv over a multi-agent env whose tensors are (E, A, ...).

    Attributes:
        num_envs: rows, E * A. num_actions: per-agent action width.
        last_info: the wrapped env's info of the latest step (episode outcomes for evaluation).
    """

    def __init__(self, env, device: str = "cpu"):
        self.env = env
        self.rows_per_env = env.policy_agents  # every robot (mid), one per team (high)
        self.num_envs = env.num_envs * self.rows_per_env
        self.num_actions = env.num_actions  # per row: (vx, vy, yaw rate) for the mid level, 2 for the high level
        self.max_episode_length = env.max_episode_length
        self.device = device
        self.cfg = env.cfg
        self._obs = self._to_tensordict(env.observations())
        self.last_info: dict = {}
        self.count_whole_only = False  # a resumed run's readouts count whole episodes only (`episode_length_buf`)

    @property
    def episode_length_buf(self) -> torch.Tensor:
        """Current episode step of every row. Shape: (E*A,)."""
        return env_flags_to_rows(self.env.episode_step, self.rows_per_env)

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        """rsl-rl spreads the episodes over their length at the start of `learn`; on a resume (`count_whole_only`)
        the envs set part-way are marked, so that their first episodes stay out of the readouts."""
        steps = from_rows(value.cpu(), self.rows_per_env)[:, 0]
        self.env.episode_step[:] = steps
        if self.count_whole_only:
            self.env.outcomes.part_way = steps > 0

    def _to_tensordict(self, obs: dict[str, torch.Tensor]) -> TensorDict:
        return TensorDict({k: to_rows(v).to(self.device) for k, v in obs.items()}, batch_size=[self.num_envs])

    def get_observations(self) -> TensorDict:
        """Current observations, without stepping or resetting."""
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """Step with actions (E*A, 3); returns obs, rewards (E*A,), dones (E*A,), extras (time_outs, log)."""
        part_way = self.env.outcomes.part_way
        part_way = None if part_way is None else part_way.clone()
        obs, reward, terminated, truncated, info = self.env.step(from_rows(actions.cpu(), self.rows_per_env))
        self._obs = self._to_tensordict(obs)
        self.last_info = info
        dones = env_flags_to_rows(terminated | truncated, self.rows_per_env).to(self.device)
        extras = {"time_outs": env_flags_to_rows(truncated, self.rows_per_env).to(self.device), "log": info["log"]}
        if part_way is not None:  # rows whose part-way episode ends now: the logger leaves them out
            extras[PART_WAY_DONE] = env_flags_to_rows(part_way & (terminated | truncated), self.rows_per_env)
        return self._obs, to_rows(reward).to(self.device), dones, extras
