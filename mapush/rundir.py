"""What a run dir holds and how to find it: its checkpoints, the latest one, whether the run is complete.

A run dir (`mapush train`) holds `config.yaml`, `overrides.yaml`, `meta.json`, `model_<it>.pt` checkpoints
written every `algo.save_interval` iterations and at the end, and the exported policy of a finished run.
"""

from __future__ import annotations

import re
from pathlib import Path

from mapush.config import META_FILE, load_run_config
from mapush.errors import BadInput

CHECKPOINT = re.compile(r"model_(\d+)\.pt$")
POLICY_FILE = "policy.pt"
"""The exported TorchScript policy: local observation (n, d) -> deterministic action (n, 3)."""
ONNX_FILE = "policy.onnx"
"""The same policy as ONNX: input `obs` (batch, d), output `actions` (batch, 3); one file, normalizer included."""
PACKAGE = Path(__file__).resolve().parent
SHIPPED_PREFIX = "shipped:"
SHIPPED_POLICIES = PACKAGE / "policies"
"""The pushing hierarchies shipped in the package (`mapush ship`): `<task>/mid` and `<task>/high` slim run dirs."""
SHIPPED_LOWLEVEL = PACKAGE / "lowlevel" / "pretrained"
"""The shipped Go1 locomotion policies, one slim run dir each: `go1` (`lowlevel=go1`'s) and `go1_strong`."""
SHIPPED_GO1 = SHIPPED_LOWLEVEL / "go1"


def shipped_names() -> list[str]:
    """Names `shipped:NAME` accepts: each shipped Go1 policy (`go1`, `go1_strong`), and `<task>` (its high level)
    or `<task>/mid` for each shipped task."""
    tasks = sorted(p.parents[1].name for p in SHIPPED_POLICIES.glob("*/high/config.yaml"))
    walkers = sorted(p.parent.name for p in SHIPPED_LOWLEVEL.glob("*/config.yaml"))
    return [*walkers, *tasks, *(f"{t}/mid" for t in tasks)]


def shipped_run(name: str) -> Path:
    """The slim run dir of `shipped:NAME`; BadInput naming the shipped ones."""
    if (SHIPPED_LOWLEVEL / name / "config.yaml").is_file():
        return SHIPPED_LOWLEVEL / name
    task, _, level = name.partition("/")
    path = SHIPPED_POLICIES / task / (level or "high")
    if not task or level not in ("", "mid", "high") or not (path / "config.yaml").is_file():
        raise BadInput(f"no shipped policy {name!r}; valid: {', '.join(SHIPPED_PREFIX + n for n in shipped_names())}")
    return path


def find_runs(root: Path) -> list[Path]:
    """The run dirs under `root` (those holding `meta.json`; not their `.hydra/` copies), in name order."""
    return sorted(p.parent for p in Path(root).glob(f"**/{META_FILE}"))


def checkpoints(run_dir: Path) -> list[Path]:
    """The run's checkpoints, oldest iteration first."""
    found = [p for p in Path(run_dir).glob("model_*.pt") if CHECKPOINT.search(p.name)]
    return sorted(found, key=checkpoint_iteration)


def checkpoint_iteration(path: Path) -> int:
    """The iteration in a checkpoint's file name (`model_<it>.pt`)."""
    return int(CHECKPOINT.search(Path(path).name).group(1))


def resolve_checkpoint(target: Path) -> tuple[Path, Path]:
    """(run dir, checkpoint) from a run dir (its latest checkpoint), a checkpoint file in one, or `shipped:NAME`."""
    if str(target).startswith(SHIPPED_PREFIX):
        target = shipped_run(str(target)[len(SHIPPED_PREFIX) :])
    target = Path(target)
    if target.is_file():
        return target.parent, target
    if not target.exists():
        raise BadInput(f"{str(target)!r} does not exist; valid: a run dir or a model_<iteration>.pt in one")
    found = checkpoints(target)
    load_run_config(target)
    if not found:
        raise BadInput(f"run dir {str(target)!r} has no checkpoint; valid: a run dir with model_*.pt")
    return target, found[-1]


def is_complete(run_dir: Path) -> bool:
    """Whether a run's last checkpoint holds all of its `train.iterations`."""
    found = checkpoints(run_dir)
    return bool(found) and checkpoint_iteration(found[-1]) + 1 >= int(load_run_config(run_dir).train.iterations)
