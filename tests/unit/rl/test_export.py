"""`policy.onnx` beside `policy.pt`: one file, dynamic batch, the same actions as the TorchScript policy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

from mapush.config import load_run_config, to_plain
from mapush.envs.mid import MidPushEnv
from mapush.envs.observations import local_dim
from mapush.lowlevel.go1 import PRETRAINED_RUN, PROPRIO_DIM
from mapush.rundir import ONNX_FILE, POLICY_FILE, shipped_run


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


def test_the_mid_level_onnx_contract_clip_and_scale_is_the_env_s_command():
    """docs/export.md: clip the ONNX output to [-1, 1] and multiply by level.action_scale, and you have the command
    the env sends to the robots."""
    run = shipped_run("cuboid/mid")
    cfg = to_plain(load_run_config(run))
    env = MidPushEnv(cfg, num_envs=4)
    obs = env.observations()["policy"]  # (4, 2, d)
    session = ort.InferenceSession(str(run / ONNX_FILE), providers=["CPUExecutionProvider"])
    (raw,) = session.run(["actions"], {"obs": obs.reshape(-1, obs.shape[-1]).numpy()})
    raw = raw * 3.0  # some beyond [-1, 1], so that the clip is tried
    assert (np.abs(raw) > 1).any() and (np.abs(raw) < 1).any()
    sent = []
    step = env.sim.step
    env.sim.step = lambda commands: (sent.append(commands.clone()), step(commands))[1]
    env.step(torch.from_numpy(raw).reshape(4, 2, 3))
    expected = np.clip(raw, -1.0, 1.0) * np.array([0.5, 0.5, 0.5])  # docs/export.md, mid level
    np.testing.assert_allclose(sent[0].reshape(-1, 3).numpy(), expected, rtol=1e-6, atol=1e-7)
