"""The Python API: build a level's env from Hydra overrides and load a trained policy, as `mapush train` and
`mapush eval` do, without the command line (notebooks, other RL libraries).

    env = make_env(["task=cylinder", "num_envs=8"])
    policy = load_policy("runs/mid/cylinder/<run>")
    obs = env.observations()["policy"]                                   # (E, A, d)
    actions = policy.actor(obs.flatten(0, 1)).view(env.num_envs, env.policy_agents, -1)
    obs, reward, terminated, truncated, info = env.step(actions)         # reward (E, A)

Mistakes (an unknown task, a bad value, a missing mid level) raise `mapush.errors.BadInput` with the same one line
the command line prints. `mapush.gym` wraps an env in gymnasium's `VectorEnv` and `Env` interfaces.
"""

from __future__ import annotations

from pathlib import Path

from mapush import levels
from mapush.config import compose_config
from mapush.errors import BadInput
from mapush.rl import policy as policies

__all__ = ["BadInput", "compose", "load_policy", "make_env"]


def compose(overrides: list[str] | None = None) -> dict:
    """The config of `mapush train OVERRIDES...` as a plain dict, checked as `mapush train` checks it (the values'
    types and ranges, then the level's own checks); BadInput for a mistake. A high level's `mid` becomes absolute."""
    return levels.checked(compose_config(list(overrides or [])))


def make_env(overrides: list[str] | None = None, evaluation: bool = False):
    """The env of `mapush train OVERRIDES...` (e.g. `["level=high", "mid=runs/mid/cuboid/<run>", "num_envs=8"]`).

    The env is batched and multi-agent: `observations()` gives `policy` (E, A, d) local and `critic` (E, A, d_c)
    observations; `step(actions (E, A, num_actions))` returns obs, reward (E, A), terminated (E,), truncated (E,)
    and info, and resets the envs that finished inside the step. Its own torch generator (`env.generator`) is
    seeded from `seed`; the global RNGs are left alone.

    Args:
        overrides: Hydra overrides, as on the command line.
        evaluation: build it as `mapush eval` does (the high levels plan their paths with OMPL where configured).
    """
    return levels.make_env(compose(overrides), evaluation)


def load_policy(path: str | Path) -> policies.Policy:
    """The deterministic policy of a run dir (its latest checkpoint) or of a `model_<it>.pt` in one, on the CPU.

    `policy.actor(obs (n, obs_dim)) -> actions (n, action_dim)`, normalizer included; its weights need no
    gradient, so it can be called outside `torch.inference_mode()`. `policy.cfg` is the run's config.
    """
    policy = policies.load_policy(path)
    policy.actor.requires_grad_(False)
    return policy
