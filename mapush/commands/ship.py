"""`mapush ship`: put a finished run into the package as a slim run dir, evaluated from the shipped files.

A slim run dir holds what loading and evaluating a policy needs: `config.yaml`, `overrides.yaml`, `meta.json`
(with `shipped_from`), the last checkpoint with the actor alone (no critic or optimizer: kB instead of MB), and
its `policy.pt` and `policy.onnx`, with their digests (`sha256.json`). A high level ships with its frozen mid
level beside it (`<out>/mid`, `<out>/high`, the high config's `mid: ../mid`), so the whole hierarchy evaluates out
of the box. The `eval.json`
written beside the policy is of the shipped files, not of the source run.
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import torch

from mapush.atomic import write_json, write_yaml
from mapush.config import load_run_config
from mapush.digests import record_weights
from mapush.errors import BadInput
from mapush.eval.rollout import evaluate
from mapush.records import read_json
from mapush.rl.export import export_onnx, export_torchscript
from mapush.rl.policy import load_policy, read_checkpoint
from mapush.rundir import ONNX_FILE, POLICY_FILE, checkpoints
from mapush.untrusted import load_yaml

RUN_FILES = ("config.yaml", "overrides.yaml", "meta.json")
MID_DIR = "mid"


def ship(run_dir: Path, out: Path, episodes: int, seeds: list[int]) -> Path:
    """Write `out` from the finished `run_dir` (and its mid level), then evaluate it; returns its eval.json.

    Everything is checked before anything is written; `out` is built beside itself and then replaces it.
    """
    run_dir, out = Path(run_dir), Path(out).resolve()
    cfg = load_run_config(run_dir)
    sources = {"": run_dir}
    if cfg.get("mid"):
        sources = {MID_DIR: Path(cfg.mid), str(cfg.level.name): run_dir}
    for source in sources.values():
        _check_finished(source)
        if _overlap(source.resolve(), out):
            raise BadInput(f"ship target {str(out)!r} overlaps the run {str(source)!r}; valid: a path outside it")
    if out.exists() and any(out.iterdir()) and not _is_shipped(out):
        raise BadInput(f"ship target {str(out)!r} holds other files; valid: a new, empty or shipped dir")
    tmp = out.with_name(f"{out.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        for sub, source in sources.items():
            write_slim(source, tmp / sub, mid=f"../{MID_DIR}" if sub and sub != MID_DIR else None)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = out.with_name(f"{out.name}.old")  # the earlier policy stays until the new one is in place
    shutil.rmtree(old, ignore_errors=True)
    if out.exists():
        os.replace(out, old)
    os.replace(tmp, out)
    shutil.rmtree(old, ignore_errors=True)
    shipped = out / next(reversed(sources))  # the evaluated policy: the run itself, or the high level over its mid
    shipped = Path(os.path.relpath(shipped))  # eval.json names the checkpoint without this machine's absolute path
    return evaluate(shipped, episodes, seeds, ["log.eval_episodes=0"], out_dir=shipped)  # no episodes.mcap


def _check_finished(run_dir: Path) -> None:
    missing = [name for name in (*RUN_FILES, POLICY_FILE) if not (run_dir / name).is_file()]
    if missing or not checkpoints(run_dir):
        what = "is not finished" if POLICY_FILE in missing else f"lacks {missing or 'a checkpoint'}"
        raise BadInput(f"run {str(run_dir)!r} {what}; valid: a finished run dir (with {POLICY_FILE})")


def _overlap(a: Path, b: Path) -> bool:
    return a == b or a.is_relative_to(b) or b.is_relative_to(a)


def _is_shipped(path: Path) -> bool:
    """Whether `path` holds an earlier `mapush ship` (which shipping again replaces)."""
    meta = (read_json(m) for m in path.glob("**/meta.json"))  # a cut one: one line naming it
    return any(isinstance(m, dict) and "shipped_from" in m for m in meta)


def write_slim(run_dir: Path, dest: Path, mid: str | None = None) -> None:
    """The slim copy of a finished run in `dest`; `mid` replaces its config's frozen mid-level path."""
    run_dir = Path(run_dir)
    dest.mkdir(parents=True)
    for name in RUN_FILES:
        shutil.copy2(run_dir / name, dest / name)
    if mid is not None:
        cfg = load_yaml(dest / "config.yaml")
        cfg.mid = mid
        write_yaml(dest / "config.yaml", cfg)
    last = checkpoints(run_dir)[-1]
    data = read_checkpoint(last)
    torch.save({"actor_state_dict": data["actor_state_dict"], "iter": data["iter"], "infos": None}, dest / last.name)
    policy = load_policy(dest)  # the exports are of the shipped checkpoint
    export_onnx(policy.actor, policy.obs_dim, dest / ONNX_FILE)
    export_torchscript(policy.actor, dest / POLICY_FILE)
    record_weights(dest)  # an altered shipped file is refused, not evaluated to 0 % (`mapush.digests`)
    meta = read_json(dest / "meta.json", run_dir / "meta.json")
    meta["command"] = without_machine_paths(meta.get("command", ""))
    meta["shipped_from"] = {"run": run_dir.name, "checkpoint": last.name}
    write_json(dest / "meta.json", meta)


ABSOLUTE_PATH = re.compile(r"(?<![\w.~])/(?:[^\s/=,\]\[]+/)+(?=[^\s/=,\]\[]+)")
"""The directories of an absolute path in a command line (what follows the last / is kept)."""


def without_machine_paths(command: str) -> str:
    """A shipped run's command without the directories of the machine it was made on (`/work/main/runs/x/mid_s0`
    becomes `.../mid_s0`): a shipped package names no one's file system."""
    return ABSOLUTE_PATH.sub(".../", command)
