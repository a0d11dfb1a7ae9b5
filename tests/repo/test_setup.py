"""tools/setup.sh chooses PyTorch's build: CUDA where an NVIDIA driver answers, else the CPU build."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from paths import REPO

SETUP = REPO / "tools" / "setup.sh"


def _build(tmp_path: Path, nvidia_smi: str | None, torch: str | None = None) -> subprocess.CompletedProcess:
    """`setup.sh --torch-build` with PATH holding only a stand-in `nvidia-smi` (exit code `nvidia_smi`) or none."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    if nvidia_smi is not None:
        fake = bin_dir / "nvidia-smi"
        fake.write_text(f"#!/bin/sh\nexit {nvidia_smi}\n")
        fake.chmod(0o755)
    env = {k: v for k, v in os.environ.items() if k != "TORCH"}
    env["PATH"] = f"{bin_dir}:/usr/bin:/bin"
    env |= {"TORCH": torch} if torch else {}
    return subprocess.run(["bash", str(SETUP), "--torch-build"], env=env, capture_output=True, text=True)


@pytest.mark.parametrize(("nvidia_smi", "build"), [(None, "cpu"), ("9", "cpu"), ("0", "cuda")])
def test_the_build_follows_the_nvidia_driver(tmp_path, nvidia_smi, build):
    """No `nvidia-smi`, or one that finds no GPU (exit 9), gets the CPU build; a working one the CUDA build."""
    proc = _build(tmp_path, nvidia_smi)
    assert proc.returncode == 0 and proc.stdout.strip() == build, proc.stderr


@pytest.mark.parametrize(("nvidia_smi", "torch"), [("0", "cpu"), (None, "cuda")])
def test_torch_decides_over_the_driver(tmp_path, nvidia_smi, torch):
    assert _build(tmp_path, nvidia_smi, torch).stdout.strip() == torch


def test_an_unknown_build_is_one_line_and_exit_2(tmp_path):
    proc = _build(tmp_path, None, "rocm")
    assert proc.returncode == 2 and proc.stderr.strip() == "setup: TORCH=rocm is not valid; valid: auto, cpu, cuda"
