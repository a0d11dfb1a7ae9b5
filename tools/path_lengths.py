"""Length of the reference paths the high level is evaluated on, per object: how far the hierarchy has to push.

The maps are those `mapush eval` draws (one env per trial, `seed` = the evaluation seed), planned with OMPL as
configured (`level.planner.*`); extra Hydra overrides (e.g. `level.planner.name=RRTstar`) follow `--`.

    python tools/path_lengths.py                       # cuboid, T-block, cylinder; 50 trials of seed 0
    python tools/path_lengths.py --tasks cylinder -- level.planner.name=RRTstar
"""

from __future__ import annotations

import argparse

from mapush.api import make_env
from mapush.planning.paths import length as path_length
from mapush.rundir import shipped_run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="cuboid,tblock,cylinder")
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("overrides", nargs="*")
    args = parser.parse_args()
    print(f"{'task':<20} {'mean':>6} {'min':>5} {'max':>5} {'straight':>8} {'path/straight':>14}   (path lengths, m)")
    for task in args.tasks.split(","):
        env = make_env(
            [
                "level=high",
                f"mid={shipped_run(f'{task}/mid')}",  # the shipped mid level: the map needs one
                f"task={task}",
                f"num_envs={args.episodes}",
                f"seed={args.seed}",
                "sim.nthread=1",
                *args.overrides,
            ],
            evaluation=True,
        )
        path = env.path  # (E, points, 2), start at the object, end at the target
        length = path_length(path)
        straight = (path[:, -1] - path[:, 0]).norm(dim=-1)
        print(
            f"{task:<20} {length.mean():6.1f} {length.min():5.1f} {length.max():5.1f} {straight.mean():8.1f}"
            f" {(length / straight).mean():14.2f}"
        )


if __name__ == "__main__":
    main()
