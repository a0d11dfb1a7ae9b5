"""`policy.onnx` beside `policy.pt`: one file, dynamic batch, the same actions as the TorchScript policy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

from mapush.envs.observations import local_dim
from mapush.lowlevel.go1 import PRETRAINED_RUN, PROPRIO_DIM
from mapush.rl.runner import ONNX_FILE, POLICY_FILE


def assert_same_actions(run_dir: Path, obs_dim: int) -> None:
    """onnxruntime on policy.onnx and torch on policy.pt agree on random observations of batch 1 and 16."""
    session = ort.InferenceSession(str(run_dir / ONNX_FILE), providers=["CPUExecutionProvider"])
    (obs,), (actions,) = session.get_inputs(), session.get_outputs()
    assert (obs.name, actions.name) == ("obs", "actions")
    assert isinstance(obs.shape[0], str) and obs.shape[1] == obs_dim  # a named, dynamic batch dim
    policy = torch.jit.load(str(run_dir / POLICY_FILE))
    generator = torch.Generator().manual_seed(0)
    for batch in (1, 16):
        x = torch.randn(batch, obs_dim, generator=generator)
        (got,) = session.run(["actions"], {"obs": x.numpy()})
        # float32: Go1 joint targets reach ~20, where one ulp is 2e-6
        np.testing.assert_allclose(got, policy(x).detach().numpy(), rtol=1e-5, atol=1e-5)


@pytest.mark.filterwarnings("ignore:`torch.jit.load` is deprecated:DeprecationWarning")
def test_a_trained_run_exports_onnx_that_acts_as_its_torchscript_policy(smoke_run):
    assert not list(smoke_run.glob("*.data")) and not list(smoke_run.glob("*.tmp"))  # weights inside, no leftovers
    assert_same_actions(smoke_run, obs_dim=local_dim(2))  # cuboid, 2 agents: 10-d local observation


@pytest.mark.filterwarnings("ignore:`torch.jit.load` is deprecated:DeprecationWarning")
def test_the_shipped_go1_policy_carries_onnx_that_acts_as_its_torchscript_policy():
    assert_same_actions(PRETRAINED_RUN, obs_dim=PROPRIO_DIM)  # the Go1's proprioception
