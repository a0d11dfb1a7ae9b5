"""A simulation that diverges in one env ends that env's episode as `diverged` and resets it, while the other env
runs on: real 2-env mid-level (`MidPushEnv`) and legged (`LocomotionEnv`) envs, stepped once with zero actions.

Three ways in: NaN written into env 1's state before the step (as an unstable simulation would leave it: MuJoCo
then resets that sim to the model's defaults itself and only counts a warning, which `BatchSim.advance` reads), the
state left non-finite by the step itself, and the batch reporting env 1 as failed (`BatchSim.advance`'s ids).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mapush.config import compose_config, to_plain
from mapush.envs.locomotion import LocomotionEnv
from mapush.envs.mid import MidPushEnv

NAN = float("nan")


@pytest.fixture(scope="module")
def mid_cfg() -> dict:
    return to_plain(compose_config(["debug=smoke"]))


@pytest.fixture(scope="module")
def low_cfg() -> dict:
    return to_plain(compose_config(["debug=smoke", "level=locomotion"]))


@pytest.fixture
def mid_env(mid_cfg) -> MidPushEnv:
    return MidPushEnv(mid_cfg, num_envs=2)


@pytest.fixture
def low_env(low_cfg) -> LocomotionEnv:
    return LocomotionEnv(low_cfg, num_envs=2)


def after_physics(monkeypatch, env, write=None, failed=()) -> None:
    """Make the physics step of every env run as usual, then `write(qpos)` into the state and report `failed`."""
    advance = env.sim.advance

    def patched(substep=None) -> np.ndarray:
        reported = advance(substep)
        if write is not None:
            write(env.sim.qpos)
        return np.union1d(reported, np.asarray(failed, dtype=np.int64))

    monkeypatch.setattr(env.sim, "advance", patched)


def check_env_1_diverged_and_restarted(env, step) -> None:
    """One step after env 1 diverged: only env 1 ends, as `diverged` (the first exception kind), with a finite
    reward, and it is restarted (episode step 0) while env 0 runs on (episode step 1)."""
    _, reward, terminated, truncated, info = step
    end = info["episode_end"]
    kind = env.exception_names.index("diverged")  # 0: the first exception the levels check
    assert kind == 0
    assert terminated.tolist() == [False, True]
    assert truncated.tolist() == [False, False]
    assert end["diverged"].tolist() == [False, True]
    assert end["exception"].tolist() == [False, True]
    assert end["success"].tolist() == [False, False]
    assert end["exception_kind"].tolist() == [-1, kind]
    assert torch.isfinite(reward).all()
    assert env.episode_step.tolist() == [1, 0]


# ---------------------------------------------------------------------------------------------------------------
# mid level: 2 envs x 2 robots, NaN in env 1's object x


def zero_mid_actions(env) -> torch.Tensor:
    return torch.zeros(2, env.num_agents, 3)


def test_mid_nan_object_position_before_the_step_ends_env_1_as_diverged(mid_env, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # MuJoCo's warning goes to MUJOCO_LOG.TXT in the working directory
    mid_env.sim.qpos[1, mid_env.sim.object_qpos] = NAN
    step = mid_env.step(zero_mid_actions(mid_env))
    check_env_1_diverged_and_restarted(mid_env, step)
    assert torch.isfinite(mid_env.state.object_xy[1]).all()
    # MuJoCo reset env 1 itself (only its warning counter tells); the env's own reset cleared that, so the next
    # step is an ordinary one
    _, _, terminated, _, info = mid_env.step(zero_mid_actions(mid_env))
    assert not info["episode_end"]["diverged"].any() and not terminated.any()


def test_mid_object_position_left_nan_by_the_step_ends_env_1_as_diverged(mid_env, monkeypatch):
    def nan_object(qpos):
        qpos[1, mid_env.sim.object_qpos] = NAN

    after_physics(monkeypatch, mid_env, write=nan_object)
    step = mid_env.step(zero_mid_actions(mid_env))
    check_env_1_diverged_and_restarted(mid_env, step)
    # the reset gave env 1 a new, finite start; its observation rows are finite
    assert torch.isfinite(mid_env.state.object_xy).all()
    assert torch.isfinite(step[0]["policy"]).all() and torch.isfinite(step[0]["critic"]).all()


def test_mid_simulation_failure_reported_for_env_1_ends_it_as_diverged(mid_env, monkeypatch):
    # the batch names env 1 as failed (a SimulationError), its state still finite
    after_physics(monkeypatch, mid_env, failed=[1])
    step = mid_env.step(zero_mid_actions(mid_env))
    check_env_1_diverged_and_restarted(mid_env, step)
    assert torch.isfinite(mid_env.state.object_xy).all()


# ---------------------------------------------------------------------------------------------------------------
# legged level: 2 Go1s, NaN in env 1's trunk height (qpos[2])


def zero_low_actions() -> torch.Tensor:
    return torch.zeros(2, 1, 12)


def test_low_nan_trunk_height_before_the_step_ends_env_1_as_diverged(low_env, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # MuJoCo's warning goes to MUJOCO_LOG.TXT in the working directory
    low_env.sim.qpos[1, 2] = NAN
    step = low_env.step(zero_low_actions())
    check_env_1_diverged_and_restarted(low_env, step)
    assert torch.isfinite(low_env.state.base_height).all()
    _, _, terminated, _, info = low_env.step(zero_low_actions())
    assert not info["episode_end"]["diverged"].any() and not terminated.any()


def test_low_trunk_height_left_nan_by_the_step_ends_env_1_as_diverged(low_env, monkeypatch):
    def nan_height(qpos):
        qpos[1, 2] = NAN

    after_physics(monkeypatch, low_env, write=nan_height)
    step = low_env.step(zero_low_actions())
    check_env_1_diverged_and_restarted(low_env, step)
    assert torch.isfinite(low_env.state.base_height).all()
    assert torch.isfinite(step[0]["policy"]).all() and torch.isfinite(step[0]["critic"]).all()


def test_low_simulation_failure_reported_for_env_1_ends_it_as_diverged(low_env, monkeypatch):
    after_physics(monkeypatch, low_env, failed=[1])
    step = low_env.step(zero_low_actions())
    check_env_1_diverged_and_restarted(low_env, step)  # asserts env 1 alone ended as diverged and restarted
    assert torch.isfinite(step[0]["policy"]).all()
