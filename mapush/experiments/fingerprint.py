"""`mapush stages fingerprint`: every level's numbers hashed, to check that a refactor changed no behaviour.

A seeded 16-env rollout (60 steps of seeded random actions) of each registered level on the cuboid, and of the
mid level on the T-block, the cylinder and with one robot (the SA baseline), hashed over observations, rewards, episode
flags and the outcomes of the episodes that end (`info["episode_end"]`). Run it at two commits and compare the
JSON lines; equal hashes mean bitwise-equal numbers. `mapush stages rekey` does that before it carries a sweep's
stages over to a commit whose configs name them differently (`rekey.py`): it runs this file on the mapush of
either checkout, so this file also runs on commits before the level factory had its own module. MID_RUN is a
mid-level cuboid run dir (e.g. `mapush train debug=smoke`) for the high level's frozen mid level.

    mapush stages fingerprint MID_RUN
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util

import torch

from mapush.config import compose_config, to_plain

if importlib.util.find_spec("mapush.levels") is not None:
    from mapush.levels import LEVELS, make_env
else:  # an older commit's mapush (`rekey` runs this file on it): the factory lived in mapush.train
    _factory = importlib.import_module("mapush.train")
    LEVELS, make_env = _factory.LEVELS, _factory.make_env

MID_VARIANTS = {
    "mid/tblock": ["task=tblock"],
    "mid/cylinder": ["task=cylinder"],
    "mid/one_robot": ["task.num_agents=1"],
}
"""Rollouts beside each level's own: {name: overrides of the mid level}."""


def _frozen_mid(level: str) -> bool:
    """Whether the level drives its robots through a frozen mid level (the registry says; before it did, the
    high level was the one)."""
    return getattr(LEVELS[level], "frozen_mid", level in BEFORE_THE_REGISTRY_SAID)


BEFORE_THE_REGISTRY_SAID = ("high",)
"""The levels with a frozen mid level in commits whose registry did not record it."""


def fingerprint(mid_run: str, envs: int = 16, steps: int = 60) -> dict[str, str]:
    """{rollout: the first 16 hex digits of the sha256 of its numbers}."""
    rollouts = {level: [f"level={level}"] + ([f"mid={mid_run}"] if _frozen_mid(level) else []) for level in LEVELS}
    rollouts |= {name: ["level=mid", *overrides] for name, overrides in MID_VARIANTS.items()}
    out = {}
    for name, overrides in sorted(rollouts.items()):
        cfg = to_plain(compose_config(["debug=smoke", "seed=3", *overrides]))
        cfg["num_envs"] = envs
        torch.manual_seed(3)
        env = make_env(cfg)
        digest = hashlib.sha256()
        gen = torch.Generator().manual_seed(0)
        for _ in range(steps):
            actions = torch.rand(envs, env.policy_agents, env.num_actions, generator=gen) * 2 - 1
            obs, reward, terminated, truncated, info = env.step(actions)
            end = info["episode_end"]
            for tensor in (obs["policy"], obs["critic"], reward, terminated, truncated, *end.values()):
                digest.update(tensor.detach().cpu().numpy().tobytes())
        out[name] = digest.hexdigest()[:16]
    return out
