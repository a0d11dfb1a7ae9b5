"""A reference for the high level: its env driven by one constant action instead of a learned policy.

Action (0, 0) puts every subgoal on the reference path, 2.25 m ahead (`envs/high.py`): plain path following, the
bar a learned high level has to clear. Same episodes, seeds, planner and metrics as `mapush eval`.

    python tools/high_reference.py MID_RUN_DIR [--action 0,0] [--episodes 50] [--seeds 0,1] [OVERRIDES...]
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch

from mapush.config import compose_config, to_plain
from mapush.eval.rollout import first_episodes
from mapush.train import build


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mid", help="the frozen mid-level run dir or checkpoint")
    parser.add_argument("--action", default="0,0", help="the constant action: turn, distance, each in [-1, 1]")
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seeds", default="0,1")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of the high-level config")
    args = parser.parse_intermixed_args()
    action = torch.tensor([float(x) for x in args.action.split(",")])
    per_seed = []
    for seed in (int(s) for s in args.seeds.split(",")):
        overrides = ["level=high", f"mid={args.mid}", f"seed={seed}", f"num_envs={args.episodes}", *args.overrides]
        env, runner = build(to_plain(compose_config(overrides)), None, 0, evaluation=True)  # as mapush eval
        per_seed.append(first_episodes(env, runner.env, lambda obs: action.expand(obs.batch_size[0], 2), seed))
    sr = np.array([r["success_rate"] for r in per_seed])
    ct = np.array([r["completion_time"] for r in per_seed])
    print(json.dumps({"action": action.tolist(), "per_seed": per_seed}, indent=2))
    print(f"action {action.tolist()}: S.R. {100 * sr.mean():.1f} +- {100 * sr.std():.1f} %, C.T. {ct.mean():.3f}")


if __name__ == "__main__":
    main()
