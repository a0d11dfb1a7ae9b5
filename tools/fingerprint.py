"""Fingerprints of every level's numbers, to check that a refactor changed no behaviour.

A seeded 16-env rollout (60 steps of seeded random actions) of each registered level, hashed over observations,
rewards, episode flags and the outcomes of the episodes that end (`info["episode_end"]`). Run it on two commits
(e.g. `git worktree add /tmp/old <commit>`, then
`PYTHONPATH=/tmp/old python tools/fingerprint.py MID_RUN` from /tmp/old) and compare the JSON lines; equal hashes
mean bitwise equal numbers. MID_RUN is a mid-level cuboid run dir (e.g. `mapush train debug=smoke`) for the
high level's frozen mid level.

    python tools/fingerprint.py MID_RUN
"""

from __future__ import annotations

import hashlib
import json
import sys

import torch

from mapush.config import compose_config, to_plain

try:
    from mapush.levels import LEVELS, make_env
except ImportError:  # commits before the level factory had its own module
    from mapush.train import LEVELS, make_env


def fingerprint(mid_run: str, envs: int = 16, steps: int = 60) -> dict[str, str]:
    """{level: the first 16 hex digits of the sha256 of its rollout's numbers}."""
    out = {}
    for level in sorted(LEVELS):
        overrides = ["debug=smoke", f"level={level}", "seed=3"] + ([f"mid={mid_run}"] if level == "high" else [])
        cfg = to_plain(compose_config(overrides))
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
        out[level] = digest.hexdigest()[:16]
    return out


if __name__ == "__main__":
    print(json.dumps(fingerprint(sys.argv[1])))
