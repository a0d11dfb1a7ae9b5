"""`mapush train --resume RUN_DIR` continues the iteration count of a cut run."""

from __future__ import annotations

import io
import json

import pytest
import torch
from mcap.reader import make_reader
from omegaconf import OmegaConf


def iterations_logged(path) -> set[int]:
    with open(path, "rb") as f:
        return {json.loads(m.data)["iteration"] for _, _, m in make_reader(f).iter_messages()}


pytestmark = pytest.mark.xdist_group("resumed_run")  # with the metrics tests: one process makes `resumed_run`


@pytest.fixture
def resumed(resumed_run):
    """The resumed run dir: 3 iterations, then 6 (read-only)."""
    return resumed_run.run


@pytest.fixture
def first(resumed_run):
    """The same run as its first 3 iterations left it (read-only)."""
    return resumed_run.first


@pytest.mark.slow
def test_resume_writes_the_next_checkpoints(resumed):
    # iterations 3-5 saved; retention (`algo.keep_checkpoints`) may have dropped the oldest of the first part
    assert {f"model_{i}.pt" for i in range(1, 6)} <= {p.name for p in resumed.glob("model_*.pt")}
    assert torch.load(resumed / "model_5.pt", weights_only=False)["iter"] == 5


@pytest.mark.slow
def test_resume_does_not_repeat_the_loaded_iteration(resumed):
    # the first run logged iterations 0-2; the resumed one 3-5 into a new metrics file
    assert iterations_logged(resumed / "metrics.mcap") == {0, 1, 2}
    assert iterations_logged(resumed / "metrics.1.mcap") == {3, 4, 5}
    log = (resumed / "train.log").read_text()
    assert log.count("Learning iteration 2/") == 1
    assert "Learning iteration 3/6" in log


def test_a_run_trained_longer_records_its_new_budget(resumed, first):
    # config.yaml says what the run learned (a cut one resumes to its end); meta.json says when and by what
    assert OmegaConf.load(resumed / "config.yaml").train.iterations == 6
    assert OmegaConf.load(resumed / ".hydra" / "config.yaml").train.iterations == 6
    assert list(OmegaConf.load(resumed / "overrides.yaml"))[-1] == "train.iterations=6"
    (step,) = json.loads((resumed / "meta.json").read_text())["lengthened"]
    assert (step["from_iterations"], step["to_iterations"]) == (3, 6)
    assert step["command"].startswith("mapush train --resume") and "commit" in step
    # the exported policy is the last iteration's, not the 3-iteration run's
    last = torch.load(resumed / "model_5.pt", weights_only=False)["actor_state_dict"]
    before = torch.load(first / "model_2.pt", weights_only=False)["actor_state_dict"]
    obs = torch.randn(4, 10)
    assert not torch.equal(torch.jit.load(resumed / "policy.pt")(obs), torch.jit.load(first / "policy.pt")(obs))
    assert any(not torch.equal(last[k], before[k]) for k in last)


def test_resume_keeps_the_earlier_checkpoints(resumed, first):
    for i in (1, 2):  # those retention keeps
        before = torch.load(first / f"model_{i}.pt", weights_only=False)["actor_state_dict"]
        after = torch.load(resumed / f"model_{i}.pt", weights_only=False)["actor_state_dict"]
        assert all(torch.equal(before[k], after[k]) for k in before)


def test_resume_starts_from_the_last_checkpoint_weights(resumed):
    # iteration 3 trains on top of model_2: its weights moved, but from model_2's (same shapes, not identical)
    one = torch.load(resumed / "model_2.pt", weights_only=False)["actor_state_dict"]
    two = torch.load(resumed / "model_3.pt", weights_only=False)["actor_state_dict"]
    assert one.keys() == two.keys()
    assert any(not torch.equal(one[k], two[k]) for k in one)


@pytest.mark.slow
def test_resuming_a_finished_run_is_refused_and_writes_no_new_checkpoint(cli, run_copy):
    proc = cli("train", "--resume", run_copy)
    assert proc.returncode == 2, proc.stderr
    assert "already has 2 iterations" in proc.stderr and "train.iterations=N with N > 2" in proc.stderr
    assert sorted(p.name for p in run_copy.glob("model_*.pt")) == ["model_0.pt", "model_1.pt"]


@pytest.mark.slow
def test_resuming_a_run_cut_before_its_export_exports_it(cli, run_copy):
    exported = {name: (run_copy / name).read_bytes() for name in ("policy.pt", "policy.onnx")}
    for name in exported:
        (run_copy / name).unlink()
    proc = cli("train", "--resume", run_copy)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in run_copy.glob("model_*.pt")) == ["model_0.pt", "model_1.pt"]  # nothing trained
    actor = torch.jit.load(run_copy / "policy.pt")
    before = torch.jit.load(io.BytesIO(exported["policy.pt"]))
    obs = torch.randn(4, 10)
    assert torch.equal(actor(obs), before(obs))
    assert (run_copy / "policy.onnx").stat().st_size > 0
