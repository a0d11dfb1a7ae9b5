"""How hard a mid level drives its robots: the statistics of its velocity commands on its own 20 s pushes.

Runs a mid-level run's deterministic actor in its task's env (the calibrated tracker unless overrides say
otherwise) for one episode length and prints, per command axis (vx, vy, yaw rate), the mean |action| (actions are
clipped to [-1, 1], then scaled by `level.action_scale`), the share of steps at or beyond 0.95 (saturated), and
the mean change per 20 ms step. Used to compare training seeds whose hierarchies transfer to Go1s differently
(results/README, "Ours on the cuboid and the cylinder, trained again").

    python tools/command_stats.py RUN_DIR [--envs N] [override ...]
"""

from __future__ import annotations

import argparse

import torch

import mapush


def command_stats(run: str, envs: int, overrides: list[str]) -> dict:
    """Successes, finished episodes and the per-axis command figures of `run` over one episode length."""
    policy = mapush.load_policy(run)
    env = mapush.make_env([f"task={policy.cfg['task']['name']}", f"num_envs={envs}", "seed=0", *overrides])
    obs = env.observations()["policy"]
    actions, succeeded, finished = [], 0, 0
    for _ in range(env.max_episode_length):
        with torch.inference_mode():
            act = policy.actor(obs.flatten(0, 1)).view(env.num_envs, env.policy_agents, -1)
        actions.append(act.clamp(-1, 1))
        step_obs, _, terminated, truncated, info = env.step(act)
        obs = step_obs["policy"]
        finished += int((terminated | truncated).sum())
        succeeded += int(info["episode_end"]["success"].sum())
    a = torch.stack(actions)  # (steps, envs, agents, 3)
    return {
        "succeeded": succeeded,
        "finished": finished,
        "mean_abs": a.abs().mean((0, 1, 2)).tolist(),
        "saturated": (a.abs() >= 0.95).float().mean((0, 1, 2)).tolist(),
        "mean_change": (a[1:] - a[:-1]).abs().mean((0, 1, 2)).tolist(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a mid-level run dir")
    parser.add_argument("--envs", type=int, default=64, help="parallel envs (default 64)")
    parser.add_argument("overrides", nargs="*", help="config overrides, e.g. sim.nthread=1")
    args = parser.parse_args()
    stats = command_stats(args.run, args.envs, args.overrides)
    print(f"{args.run}: {stats['succeeded']} of {stats['finished']} pushes succeeded")
    for key in ("mean_abs", "saturated", "mean_change"):
        print(f"  {key:12s} (vx, vy, yaw rate): " + ", ".join(f"{v:.3f}" for v in stats[key]))


if __name__ == "__main__":
    main()
