"""A reference for the high level: its env driven by one constant action instead of a learned policy.

Action (0, 0) puts every subgoal on the reference path, 2.25 m ahead (`envs/high.py`): plain path following, the
bar a learned high level has to clear. Same episodes, seeds, planner and metrics as `mapush eval`.

    python tools/high_reference.py MID_RUN_DIR [--action 0,0] [--episodes 50] [--seeds 0,1] [OVERRIDES...]
"""

from __future__ import annotations

import argparse
import json

import torch

from mapush.config import compose_config, to_plain
from mapush.eval.rollout import first_episodes, summarize
from mapush.levels import build


def constant_action(cfg: dict, action: list[float], episodes: int, seeds: list[int]) -> dict:
    """The eval record (as `mapush eval` writes it) of a high-level config (`cfg`) driven by one action."""
    fixed = torch.tensor(action, dtype=torch.float32)
    per_seed = []
    for seed in seeds:
        env, runner = build({**cfg, "seed": seed, "num_envs": episodes}, None, 0, evaluation=True)  # as mapush eval
        act = lambda obs, env=env: fixed.expand(obs.batch_size[0], env.num_actions)  # noqa: E731
        per_seed.append(first_episodes(env, runner.env, act, seed))
    return summarize(cfg, f"constant action {fixed.tolist()}", episodes, seeds, per_seed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mid", help="the frozen mid-level run dir or checkpoint")
    parser.add_argument("--action", default="0,0", help="the constant action: turn, distance, each in [-1, 1]")
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seeds", default="0,1")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of the high-level config")
    args = parser.parse_intermixed_args()
    cfg = to_plain(compose_config(["level=high", f"mid={args.mid}", *args.overrides]))
    action = [float(x) for x in args.action.split(",")]
    result = constant_action(cfg, action, args.episodes, [int(s) for s in args.seeds.split(",")])
    print(json.dumps(result, indent=2))
    sr, sr_std, ct = result["success_rate"], result["success_rate_std"], result["completion_time"]
    print(f"action {action}: S.R. {100 * sr:.1f} +- {100 * sr_std:.1f} %, C.T. {ct:.3f}")


if __name__ == "__main__":
    main()
