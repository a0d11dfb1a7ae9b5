"""Every record written whole or not at all: write a temp file beside the target, fsync it, rename it over.

A rename within one directory is atomic, so a reader (or a later command) sees the old file or the new one, never
half of one: a kill, a full disk or a second writer at the same moment leaves no torn `config.yaml`, `eval.json`
or checkpoint. Temp files are hidden (`.NAME.HOST.PID.tmp`), so globs for records (`model_*.pt`, `eval*.json`) never
see them, and two processes never share one.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import socket
from collections.abc import Iterator
from pathlib import Path

HOST = socket.gethostname().replace(".", "-")
"""This machine's name in temp files: on a filesystem that several machines share, each reaps only its own."""


def temp_path(target: Path) -> Path:
    """The hidden, per-process temp file that becomes `target`: `.NAME.HOST.PID.tmp`."""
    target = Path(target)
    return target.with_name(f".{target.name}.{HOST}.{os.getpid()}.tmp")


@contextlib.contextmanager
def replacing(target: Path) -> Iterator[Path]:
    """Yield a temp path to write `target`'s new contents to (by any writer: torch.save, savefig, MCAP); on
    success it is synced and renamed over `target`, on failure removed, leaving `target` as it was."""
    target = Path(target)
    tmp = temp_path(target)
    try:
        yield tmp
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def write_text(target: Path, text: str) -> Path:
    """`target.write_text(text)`, atomically."""
    with replacing(target) as tmp:
        tmp.write_text(text)
    return Path(target)


def write_json(target: Path, data) -> Path:
    """`data` as indented JSON with a final newline, atomically."""
    return write_text(target, json.dumps(data, indent=2) + "\n")


def write_yaml(target: Path, cfg, resolve: bool = False) -> Path:
    """An OmegaConf config (or a plain container) as YAML, atomically."""
    from omegaconf import OmegaConf

    node = cfg if OmegaConf.is_config(cfg) else OmegaConf.create(cfg)
    return write_text(target, OmegaConf.to_yaml(node, resolve=resolve))


@contextlib.contextmanager
def locked(directory: Path) -> Iterator[None]:
    """Hold an exclusive lock on an existing directory (no lock file is made): a second holder waits until the
    first is done. The lock goes with the process, so a killed holder never leaves it taken."""
    fd = os.open(directory, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError:  # NFS emulates flock with fcntl locks, which need a file open for writing
            os.close(fd)
            fd = os.open(Path(directory) / ".lock", os.O_WRONLY | os.O_CREAT, 0o644)
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def remove_leftovers(directory: Path) -> list[Path]:
    """Delete temp files of this machine's writers that are gone (`.NAME.HOST.PID.tmp` whose process no longer
    runs here); returns them. Other machines' temp files are theirs to reap."""
    removed = []
    for tmp in Path(directory).glob(f".*.{HOST}.*.tmp"):
        pid = tmp.name.rsplit(".", 2)[-2]
        if pid.isdigit() and not _alive(int(pid)):
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
