"""A read-only or full filesystem: one line, exit 2, nothing half-made, no earlier record lost.

Each test mounts a small tmpfs (root only; skipped elsewhere)."""

from __future__ import annotations

import contextlib
import shutil
import subprocess
from pathlib import Path

import pytest
from stand_ins import assert_bad_input


@contextlib.contextmanager
def tmpfs(where: Path, size: str, read_only: bool = False):
    """A tmpfs of `size` at `where` for the block; skips the test where mounting is not allowed."""
    where.mkdir(parents=True, exist_ok=True)
    options = f"size={size}" + (",ro" if read_only else "")
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True)
    if proc.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.decode().strip()}")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


@pytest.mark.slow
def test_training_onto_a_read_only_filesystem_is_one_line(cli, tmp_path):
    with tmpfs(tmp_path / "ro", "1m", read_only=True) as root:
        proc = cli("train", "debug=smoke", f"train.run_root={root}")
        assert_bad_input(proc, "Read-only file system", "valid: a writable dir")
        assert not any(root.iterdir())


@pytest.mark.slow
def test_training_onto_a_full_filesystem_leaves_no_half_made_run(cli, tmp_path):
    with tmpfs(tmp_path / "full", "8k") as root:
        (root / "filler").write_bytes(b"\0" * 6000)
        proc = cli("train", "debug=smoke", f"train.run_root={root}")
        assert_bad_input(proc, "No space left on device", "valid: a writable dir")
        assert not list((root).glob("mid/cuboid/*"))


@pytest.mark.slow
def test_an_evaluation_that_fills_the_disk_keeps_the_earlier_eval_json(cli, run_copy, tmp_path):
    with tmpfs(tmp_path / "full", "4m") as root:
        run = Path(shutil.copytree(run_copy, root / "run"))
        (run / "eval.json").write_text('{"success_rate": 0.5}\n')
        free = shutil.disk_usage(root).free
        (root / "filler").write_bytes(b"\0" * max(free - 8192, 0))
        proc = cli("eval", run, "--episodes", "2", "--seeds", "0")
        assert_bad_input(proc, "No space left on device")
        assert (run / "eval.json").read_text() == '{"success_rate": 0.5}\n'
        assert not list(run.glob(".*.tmp"))
