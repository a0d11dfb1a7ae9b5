"""`mapush export RUN`: one checkpoint's policy to a new dir, for a run cut before its end or any checkpoint."""

from __future__ import annotations

import shutil

import pytest
import torch


@pytest.mark.slow  # over 8 s on the idle 2-core machine (10-11 s, 2026-12-07)
def test_a_cut_run_exports_its_last_checkpoint_to_a_new_dir_and_stays_cut(cli, smoke_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(smoke_run, run)
    for name in ("policy.pt", "policy.onnx"):  # as a run cut after its last checkpoint, before its export
        (run / name).unlink()
    proc = cli("export", run)
    assert proc.returncode == 0, proc.stderr
    out = run / "export_1"
    assert proc.stdout.strip().endswith("export_1") and (out / "policy.onnx").is_file()
    assert not (run / "policy.pt").exists()  # the run is left cut: `--resume` finishes it
    exported, shipped = torch.jit.load(out / "policy.pt"), torch.jit.load(smoke_run / "policy.pt")
    width = next(p for p in shipped.parameters() if p.dim() == 2).shape[1]
    obs = torch.randn(3, width)
    assert torch.allclose(exported(obs), shipped(obs))  # the same actor as the finished run exported


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_export_refuses_an_existing_dir_and_a_foreign_checkpoint_in_one_line(cli, smoke_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(smoke_run, run)
    (tmp_path / "taken").mkdir()
    for args, named in (
        (("-o", tmp_path / "taken"), "exists"),
        (("--checkpoint", tmp_path / "model_1.pt"), "is not a checkpoint of"),
    ):
        proc = cli("export", run, *args)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert named in proc.stderr
    assert not list(run.glob("export_*"))
