"""How hard a mid level drives its robots: the statistics of its velocity commands on its own 20 s pushes.

Runs `mapush eval`'s first-episode rollout (one push in each of N envs, seed 0) of a mid-level run, as trained or
with the given overrides (e.g. `lowlevel=go1`), and watches every step of each env's first episode. It prints,
per command axis (vx, vy, yaw rate), the commands as shares of `level.action_scale` (the policy's clipped
actions): their mean magnitude, the share of steps at or beyond 0.95 (saturated), and the mean change per 20 ms
step. Used to compare training seeds whose hierarchies transfer to Go1s differently (results/README, "Ours on the
cuboid and the cylinder, trained again").

    python tools/command_stats.py RUN_DIR [--episodes N] [override ...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.eval.rollout import run_episodes
from mapush.rundir import checkpoints

SATURATED = 0.95
"""A command at or beyond this share of the action scale counts as saturated."""


class CommandWatch:
    """A recorder (`capture` every step) of each env's first-episode commands, as shares of the action scale."""

    def __init__(self, action_scale: list[float]):
        self.scale = torch.tensor(action_scale)
        self.ended = self.last = None
        self.steps = torch.zeros(())
        self.magnitude, self.saturated, self.change = torch.zeros(3), torch.zeros(3), torch.zeros(3)

    def watch(self, *args, **kwargs) -> None:
        pass

    def capture(self, env, commands, reward, parts, done) -> None:
        share = commands / self.scale  # (E, A, 3) in [-1, 1]
        if self.ended is None:
            self.ended, self.last = torch.zeros(env.num_envs, dtype=torch.bool), share.clone()
        live = (~self.ended).float()[:, None, None]  # (E, 1, 1): robot-steps of first episodes only
        self.steps += live.sum() * env.num_agents
        self.magnitude += (share.abs() * live).sum((0, 1))
        self.saturated += ((share.abs() >= SATURATED) * live).sum((0, 1))
        self.change += ((share - self.last).abs() * live).sum((0, 1))
        self.last, self.ended = share.clone(), self.ended | done

    def figures(self) -> dict[str, list[float]]:
        totals = {"mean_abs": self.magnitude, "saturated": self.saturated, "mean_change": self.change}
        return {key: (total / self.steps).tolist() for key, total in totals.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="a mid-level run dir")
    parser.add_argument("--episodes", type=int, default=64, help="pushes, one per env (default 64)")
    parser.add_argument("overrides", nargs="*", help="config overrides, e.g. lowlevel=go1")
    args = parser.parse_args()
    cfg = to_plain(apply_overrides(load_run_config(args.run), ["sim.nthread=1", *args.overrides]))
    cfg["log"]["eval_episodes"] = 0
    watch = CommandWatch(cfg["level"]["action_scale"])
    out = run_episodes(cfg, checkpoints(args.run)[-1], args.episodes, 0, recorders=(watch,))
    print(f"{args.run}: S.R. {out['success_rate']:.2f} over {args.episodes} pushes")
    for key, values in watch.figures().items():
        print(f"  {key:12s} (vx, vy, yaw rate): " + ", ".join(f"{v:.3f}" for v in values))


if __name__ == "__main__":
    main()
