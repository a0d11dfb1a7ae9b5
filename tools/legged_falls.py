"""Where the legged robots fall: a hierarchy evaluated on Go1s, and what is near each robot when it tips over.

Runs `mapush eval`'s first-episode rollout (one episode in each of N envs, seed 0) with `lowlevel=go1` and
watches every inner step of each env's first episode. At the first step where a robot tilts beyond the high
level's `robot_tilt` limit, it records that robot's distances (centre to centre) to the object, to its nearest
teammate and to the nearest obstacle block, and whether its command was at the mid level's full scale on every
axis (against how often any robot's command is, over all steps of the first episodes). It prints the exception
shares of the evaluation and the quartiles of those distances, so that a reader can tell falls while pushing or
crowding from falls at walls or blocks.

    python tools/legged_falls.py RUN_DIR/model_<it>.pt [overrides] [--episodes N]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.eval.rollout import run_episodes


class FallWatch:
    """A recorder (`capture` every inner step) that keeps each env's first fall."""

    def __init__(self, max_tilt: float):
        self.max_tilt, self.falls, self.seen, self.ended = max_tilt, [], None, None
        self.robot_steps, self.saturated_steps = 0, 0  # over every robot and step of the first episodes

    def watch(self, *args, **kwargs) -> None:
        pass

    def capture(self, env, commands, reward, parts, done) -> None:
        s = env.state
        if self.seen is None:
            self.seen = torch.zeros(env.num_envs, dtype=torch.bool)
            self.ended = torch.zeros(env.num_envs, dtype=torch.bool)
        fell = (s.robot_tilt > self.max_tilt).any(1) & ~self.seen & ~self.ended
        saturated = (commands.abs() >= 0.99 * env.mid.action_scale).all(-1)  # (E, A)
        self.robot_steps += int((~self.ended).sum()) * env.num_agents
        self.saturated_steps += int(saturated[~self.ended].sum())
        self.seen |= fell
        self.ended |= done  # only first episodes count, as in the evaluation
        for e in fell.nonzero().flatten().tolist():
            a = int(s.robot_tilt[e].argmax())
            teammates = s.robot_distance[e, a][torch.arange(env.num_agents) != a]
            blocks = (env.obstacles[e, :, :2] - s.robot_xy[e, a]).norm(dim=1)
            self.falls.append(
                {
                    "time_s": float(env.episode_time_s[e]),
                    "object_m": float((s.robot_xy[e, a] - s.object_xy[e]).norm()),
                    "teammate_m": float(teammates.min()) if len(teammates) else float("nan"),
                    "obstacle_m": float(blocks.min()) if len(blocks) else float("nan"),
                    "saturated_command": bool(saturated[e, a]),
                }
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint", type=Path)
    parser.add_argument("overrides", nargs="*")
    parser.add_argument("--episodes", type=int, default=50)
    args = parser.parse_args()
    cfg = to_plain(apply_overrides(load_run_config(args.checkpoint.parent), ["lowlevel=go1", *args.overrides]))
    cfg["log"]["eval_episodes"] = 0
    watch = FallWatch(float(cfg["level"]["exceptions"]["robot_tilt"]["params"]["max_rad"]))
    out = run_episodes(cfg, args.checkpoint, args.episodes, 0, recorders=(watch,))
    print(f"success {out['success_rate']:.2f}; episodes ended by: "
          + ", ".join(f"{k} {v:.2f}" for k, v in out["exceptions"].items() if v))  # fmt: skip
    print(f"{len(watch.falls)} envs with a fall; quartiles (25 / 50 / 75 %):")
    for key in ("time_s", "object_m", "teammate_m", "obstacle_m"):
        values = np.array([f[key] for f in watch.falls])
        print(f"  {key:11s} " + " / ".join(f"{q:.2f}" for q in np.nanpercentile(values, [25, 50, 75])))
    saturated = np.mean([f["saturated_command"] for f in watch.falls])
    overall = watch.saturated_steps / max(watch.robot_steps, 1)
    print(f"  commands at full scale on all three axes: {saturated:.2f} of the falls, {overall:.2f} of all robot-steps")


if __name__ == "__main__":
    main()
