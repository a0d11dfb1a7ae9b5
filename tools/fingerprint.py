"""Fingerprints of every level's numbers, to check that a refactor changed no behaviour.

A seeded 16-env rollout (60 steps of seeded random actions) of each registered level on the cuboid, and of the
mid level on every other task and with one robot (the SA baseline), hashed over observations, rewards, episode
flags and the outcomes of the episodes that end (`info["episode_end"]`). Run it on two commits
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
from pathlib import Path

import torch

import mapush
from mapush.config import compose_config, to_plain

if (Path(mapush.__file__).parent / "levels.py").is_file():
    from mapush.levels import LEVELS, make_env
else:  # commits before the level factory had its own module (an editable install would lend a newer one)
    from mapush.train import LEVELS, make_env


MID_VARIANTS = {
    "mid/tblock": ["task=tblock"],
    "mid/cylinder": ["task=cylinder"],
    "mid/one_robot": ["task.num_agents=1"],
}
"""Rollouts beside each level's own: {name: overrides of the mid level}."""


def fingerprint(mid_run: str, envs: int = 16, steps: int = 60) -> dict[str, str]:
    """{rollout: the first 16 hex digits of the sha256 of its numbers}."""
    rollouts = {level: [f"level={level}"] + ([f"mid={mid_run}"] if level == "high" else []) for level in LEVELS}
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


if __name__ == "__main__":
    print(json.dumps(fingerprint(sys.argv[1])))
