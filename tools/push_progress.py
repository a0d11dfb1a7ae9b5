"""Where the object goes in a mid level's pushes, and on which side of it the robots stand.

Runs `mapush eval`'s first-episode rollout (one 20 s push in each of N envs, seed 0) of a mid-level run, as trained
and with each given override set (e.g. `lowlevel=go1`), and watches every step of each env's first episode: the
object's distance to its subgoal at the start and at the end, and how many robot-steps each robot spends ahead of
the object (on the subgoal's side of the line through the object's centre, square to the push) rather than behind
it, where a pusher stands. It prints, for successes and failures apart, those figures' means, and the share of
failed pushes that ended with the object farther from its subgoal than it started.

    python tools/push_progress.py RUN_DIR [--episodes N] [--compare lowlevel=go1 ...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.eval.rollout import run_episodes
from mapush.rundir import checkpoints


class PushWatch:
    """A recorder (`capture` every step) of each env's first push: start and end distance, robots ahead."""

    def __init__(self):
        self.start = self.last = self.ended = self.succeeded = None
        self.ahead_steps = self.robot_steps = None

    def watch(self, *args, **kwargs) -> None:
        pass

    def capture(self, env, commands, reward, parts, done) -> None:
        s = env.state
        distance = torch.linalg.vector_norm(s.object_xy - env.subgoal_xy, dim=-1)
        if self.start is None:
            self.start, self.last = distance.clone(), distance.clone()
            self.ended = torch.zeros(env.num_envs, dtype=torch.bool)
            self.succeeded = torch.zeros(env.num_envs, dtype=torch.bool)
            self.ahead_steps = torch.zeros(env.num_envs)
            self.robot_steps = torch.zeros(env.num_envs)
        live = ~self.ended
        push = env.subgoal_xy - s.object_xy  # (E, 2)
        ahead = ((s.robot_xy - s.object_xy.unsqueeze(1)) * push.unsqueeze(1)).sum(-1) > 0  # (E, A)
        self.ahead_steps += (ahead.sum(1) * live).float()
        self.robot_steps += live.float() * env.num_agents
        self.last = torch.where(live, distance, self.last)
        self.succeeded |= env.success & live
        self.ended |= done


def report(label: str, out: dict, watch: PushWatch) -> None:
    success = watch.succeeded
    print(f"{label}: S.R. {out['success_rate']:.2f}")
    ahead = watch.ahead_steps / watch.robot_steps.clamp(min=1)
    for name, rows in (("successes", success), ("failures", ~success)):
        if rows.any():
            farther = (watch.last[rows] > watch.start[rows]).float().mean()
            print(f"  {name:9s} {int(rows.sum()):3d}: distance to the subgoal {watch.start[rows].mean():.2f} -> "
                  f"{watch.last[rows].mean():.2f} m; ended farther than it started {farther:.2f}; "
                  f"robot-steps ahead of the object {ahead[rows].mean():.2f}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--compare", nargs="*", default=[], help="overrides to evaluate with besides as trained")
    args = parser.parse_args()
    checkpoint = checkpoints(args.run)[-1]
    for overrides in [[], args.compare] if args.compare else [[]]:
        cfg = to_plain(apply_overrides(load_run_config(args.run), ["sim.nthread=1", *overrides]))
        cfg["log"]["eval_episodes"] = 0
        watch = PushWatch()
        out = run_episodes(cfg, checkpoint, args.episodes, 0, recorders=(watch,))
        report(" ".join(overrides) or "as trained", out, watch)


if __name__ == "__main__":
    main()
