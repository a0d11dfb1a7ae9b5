"""`mapush ship`: put a finished run into the package as a slim run dir, evaluated from the shipped files.

A slim run dir holds what loading and evaluating a policy needs: `config.yaml`, `overrides.yaml`, `meta.json`
(with `shipped_from`), the last checkpoint with the actor alone (no critic or optimizer: kB instead of MB), and
its `policy.pt` and `policy.onnx`. A high level ships with its frozen mid level beside it (`<out>/mid`,
`<out>/high`, the high config's `mid: ../mid`), so the whole hierarchy evaluates out of the box. The `eval.json`
written beside the policy is of the shipped files, not of the source run.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import torch
from omegaconf import OmegaConf

from mapush.config import load_run_config
from mapush.errors import BadInput
from mapush.eval.rollout import evaluate
from mapush.rl.export import export_onnx
from mapush.rl.policy import load_policy, read_checkpoint
from mapush.rl.runner import ONNX_FILE, POLICY_FILE
from mapush.rundir import checkpoints

RUN_FILES = ("config.yaml", "overrides.yaml", "meta.json")
MID_DIR = "mid"


def ship(run_dir: Path, out: Path, episodes: int, seeds: list[int]) -> Path:
    """Write `out` from the finished `run_dir` (and its mid level), then evaluate it; returns its eval.json."""
    run_dir, out = Path(run_dir), Path(out)
    cfg = load_run_config(run_dir)
    if not (run_dir / POLICY_FILE).is_file() or not checkpoints(run_dir):
        raise BadInput(f"run {str(run_dir)!r} is not finished (no {POLICY_FILE}); valid: a finished run dir")
    tmp = out.with_name(f"{out.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    if cfg.get("mid"):
        write_slim(Path(cfg.mid), tmp / MID_DIR)
        policy_dir = f"{cfg.level.name}"
        write_slim(run_dir, tmp / policy_dir, mid=f"../{MID_DIR}")
    else:
        policy_dir = ""
        write_slim(run_dir, tmp)
    shutil.rmtree(out, ignore_errors=True)
    os.replace(tmp, out)
    shipped = out / policy_dir
    return evaluate(shipped, episodes, seeds, ["log.eval_episodes=0"], out_dir=shipped)  # no episodes.mcap


def write_slim(run_dir: Path, dest: Path, mid: str | None = None) -> None:
    """The slim copy of a finished run in `dest`; `mid` replaces its config's frozen mid-level path."""
    run_dir = Path(run_dir)
    missing = [name for name in RUN_FILES if not (run_dir / name).is_file()]
    if missing or not checkpoints(run_dir):
        raise BadInput(f"run {str(run_dir)!r} lacks {missing or 'a checkpoint'}; valid: a finished run dir")
    dest.mkdir(parents=True)
    for name in RUN_FILES:
        shutil.copy2(run_dir / name, dest / name)
    if mid is not None:
        cfg = OmegaConf.load(dest / "config.yaml")
        cfg.mid = mid
        OmegaConf.save(cfg, dest / "config.yaml")
    last = checkpoints(run_dir)[-1]
    data = read_checkpoint(last)
    torch.save({"actor_state_dict": data["actor_state_dict"], "iter": data["iter"], "infos": None}, dest / last.name)
    policy = load_policy(dest)  # the exports are of the shipped checkpoint
    export_onnx(policy.actor, policy.obs_dim, dest / ONNX_FILE)
    torch.jit.script(policy.actor).save(str(dest / POLICY_FILE))
    meta = json.loads((dest / "meta.json").read_text())
    meta["shipped_from"] = {"run": run_dir.name, "checkpoint": last.name}
    (dest / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
