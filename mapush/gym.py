"""gymnasium (1.x) views of a mapush env, for RL libraries that speak gymnasium rather than rsl-rl.

`VectorEnv` is the whole batch: per env, the observation is the policy agents' local observations (A, d) and the
action their raw actions (A, num_actions), as one shared policy sees them. `SingleEnv` is one env (num_envs=1) as a
plain `gymnasium.Env`, which `gymnasium.utils.env_checker.check_env` accepts.

    env = VectorEnv(mapush.make_env(["num_envs=8"]))
    obs, info = env.reset(seed=0)                                       # (8, A, d)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium
import numpy as np
import torch
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from mapush.errors import BadInput

FINAL_INFO_KEYS = ("success", "exception", "exception_kind", "time_s")
"""The per-episode outcomes (`info["episode_end"]` of a mapush env) reported in `final_info` when an episode ends."""


def _numpy(tensor: torch.Tensor) -> np.ndarray:
    """A fresh numpy copy: the env may write its tensors in place later, and gymnasium wants new data per call."""
    return tensor.detach().cpu().numpy().copy()


class VectorEnv(gymnasium.vector.VectorEnv):
    """A mapush env (any level, from `mapush.make_env`) as a gymnasium `VectorEnv` of `env.num_envs` envs.

    - Observation per env: `observations()["policy"]`, (A, d) float32 (A: the policy agents, 1 for the high level).
    - Action per env: (A, num_actions) float32 in [-1, 1] (+-4 for the locomotion level).
    - Reward per env: the mean of its agents' rewards, the team reward (each mid-level agent is scored on its own
      terms; their mean is what one team policy maximizes). The per-agent rewards are in `info["agent_rewards"]`
      (E, A), for learners that train the agents as rows, as mapush itself does.
    - Autoreset: `AutoresetMode.SAME_STEP`. A mapush env resets its finished envs inside `step`, so the observation
      returned for a finished env is the first of its next episode; the last one of the finished episode is in
      `info["final_obs"]` (an object array, None for the others; mask `info["_final_obs"]`) and its outcomes
      (`success`, `exception`, `exception_kind`, `time_s`) in `info["final_info"]`, as gymnasium's own vector envs
      report them.
    - Seeding: `reset(seed=s)` reseeds the env's one generator for the whole batch (not one seed per env), so a
      seeded reset repeats its layouts. Draws made once at construction (the locomotion level's friction and mass)
      and OMPL's plans at evaluation keep their own seeds.

    Args:
        env: the mapush env; the view takes over its `reset` (to see each finished episode's last observation).
    """

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, env):
        self.env = env
        self.num_envs = env.num_envs
        self._env_reset = env.reset
        env.reset = self._reset_finished  # the env resets its finished envs with self.reset(ids) at the end of step
        self._final_obs: np.ndarray | None = None
        obs = env.observations()["policy"]
        self._action_shape = (env.num_envs, env.policy_agents, env.num_actions)
        limit = env.action_limit
        self.single_observation_space = gymnasium.spaces.Box(-np.inf, np.inf, tuple(obs.shape[1:]), np.float32)
        self.single_action_space = gymnasium.spaces.Box(-limit, limit, self._action_shape[1:], np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

    def _reset_finished(self, ids: np.ndarray) -> None:
        """Called by the env's step on its finished envs: keep their last observation, then reset them."""
        if len(ids):
            self._final_obs = _numpy(self.env.observations()["policy"])
        self._env_reset(ids)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start new episodes in every env, or in those of `options["reset_mask"]` ((E,) bool).

        Args:
            seed: reseeds the env's generator (and the locomotion level's numpy generator); None continues it.

        Returns:
            observations (E, A, d) and an empty info.
        """
        if seed is not None and not isinstance(seed, int | np.integer):
            raise BadInput(f"seed {seed!r}: one generator draws every env's layout; valid: an int or None")
        super().reset(seed=seed)
        if seed is not None:
            self.env.seed(int(seed))
        mask = (options or {}).get("reset_mask")
        ids = np.arange(self.num_envs) if mask is None else np.flatnonzero(np.asarray(mask, dtype=bool))
        self._env_reset(ids)
        return _numpy(self.env.observations()["policy"]), {}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advance every env by one policy step (and reset those that finish: `AutoresetMode.SAME_STEP`).

        Args:
            actions: (E, A, num_actions).

        Returns:
            obs (E, A, d), reward (E,) the mean over agents, terminated (E,), truncated (E,), info (see the class).
        """
        actions = torch.as_tensor(np.asarray(actions, dtype=np.float32)).reshape(self._action_shape)
        self._final_obs = None
        obs, reward, terminated, truncated, env_info = self.env.step(actions)
        info: dict[str, Any] = {"agent_rewards": _numpy(reward), "_agent_rewards": np.ones(self.num_envs, bool)}
        done = _numpy(terminated | truncated)
        if done.any():
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):  # gymnasium's layout: one array per finished env
                final_obs[i] = self._final_obs[i]
            end = env_info["episode_end"]
            final_info = {key: _numpy(end[key]) for key in FINAL_INFO_KEYS}
            final_info.update({f"_{key}": done.copy() for key in FINAL_INFO_KEYS})
            info.update(final_obs=final_obs, _final_obs=done.copy(), final_info=final_info, _final_info=done.copy())
        return _numpy(obs["policy"]), _numpy(reward.mean(-1)), _numpy(terminated), _numpy(truncated), info

    def close_extras(self, **kwargs: Any) -> None:
        """Give the env its own `reset` back."""
        vars(self.env).pop("reset", None)


class SingleEnv(gymnasium.Env):
    """One mapush env (built with `num_envs=1`) as a `gymnasium.Env`: observation (A, d), action (A, num_actions).

    Episodes end as gymnasium expects: the step that terminates or truncates returns the episode's last
    observation, and the caller calls `reset()`. (The env underneath has already started its next episode; a
    `reset()` starts a fresh one.) Reward is the mean of the agents' rewards, as in `VectorEnv`; `info` holds
    `agent_rewards` (A,) and, at an episode's end, its `success`, `exception`, `exception_kind` and `time_s`.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(self, env):
        if env.num_envs != 1:
            raise BadInput(
                f"SingleEnv wraps one env, not num_envs={env.num_envs}; valid: make_env([..., 'num_envs=1'])"
            )
        self.vector = VectorEnv(env)
        self.observation_space = self.vector.single_observation_space
        self.action_space = self.vector.single_action_space

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """A new episode; `seed` reseeds the env's generator (see `VectorEnv.reset`)."""
        super().reset(seed=seed)
        obs, info = self.vector.reset(seed=seed)
        return obs[0], info

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One policy step; at an episode's end the observation is its last one, not the next episode's first."""
        obs, reward, terminated, truncated, vector_info = self.vector.step(np.asarray(action)[None])
        info: dict[str, Any] = {"agent_rewards": vector_info["agent_rewards"][0]}
        if "final_obs" in vector_info:
            obs = vector_info["final_obs"]  # (1,) object array: the last observation
            info.update({key: vector_info["final_info"][key][0] for key in FINAL_INFO_KEYS})
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), info

    def close(self) -> None:
        """Close the vector view (the env gets its own `reset` back)."""
        self.vector.close()
