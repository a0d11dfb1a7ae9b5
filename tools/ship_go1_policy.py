"""Ship a trained Go1 locomotion policy in the package, as `lowlevel=go1`'s default (`lowlevel.policy: null`).

Copies a finished `mapush train level=low` run into `mapush/lowlevel/pretrained/go1/` as a slim run dir:
its config, overrides and meta, the TorchScript `policy.pt` the go1 backend runs, and its last checkpoint with the
actor alone (no critic, no optimizer: a few hundred kB instead of MBs). Then it evaluates what it shipped with
`mapush eval`'s own code, so the `eval.json` beside the policy is of the shipped files, not of the source run.

    python tools/ship_go1_policy.py RUN_DIR [--episodes 200] [--seeds 0,1]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
from pathlib import Path

import torch

from mapush.config import load_run_config
from mapush.eval.rollout import evaluate
from mapush.lowlevel.go1 import PRETRAINED_RUN
from mapush.rl.runner import POLICY_FILE, checkpoints

RUN_FILES = ("config.yaml", "overrides.yaml", "meta.json", POLICY_FILE)


def ship(run_dir: Path, episodes: int, seeds: list[int], out: Path = PRETRAINED_RUN) -> Path:
    """Write the slim run dir `out` from `run_dir` and evaluate it; returns its eval.json."""
    cfg = load_run_config(run_dir)
    if cfg.level.name != "low":
        raise SystemExit(f"{run_dir} is a level={cfg.level.name} run; valid: a level=low run")
    missing = [name for name in RUN_FILES if not (run_dir / name).is_file()]
    if missing or not checkpoints(run_dir):
        raise SystemExit(f"{run_dir} lacks {missing or 'a checkpoint'}; valid: a finished level=low run")
    last = checkpoints(run_dir)[-1]
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    for name in RUN_FILES:
        shutil.copy2(run_dir / name, out / name)
    data = torch.load(last, weights_only=True, map_location="cpu")
    slim = {"actor_state_dict": data["actor_state_dict"], "iter": data["iter"], "infos": data.get("infos")}
    torch.save(slim, out / last.name)
    meta = json.loads((out / "meta.json").read_text())
    meta["shipped_from"] = {"run": run_dir.name, "checkpoint": last.name}
    (out / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    shipped = Path(os.path.relpath(out))  # eval.json names the checkpoint without this machine's absolute path
    return evaluate(shipped, episodes, seeds, ["log.eval_episodes=0"])  # no episodes.mcap in the package


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a finished level=low run dir")
    parser.add_argument("--episodes", type=int, default=200, help="20 s episodes per seed for the shipped eval")
    parser.add_argument("--seeds", default="0,1")
    args = parser.parse_args()
    path = ship(args.run, args.episodes, [int(s) for s in args.seeds.split(",")])
    result = json.loads(path.read_text())
    print(f"{path}: velocity_error {result['velocity_error']:.3f} m/s, fall_rate {result['fall_rate']:.3%}")


if __name__ == "__main__":
    main()
