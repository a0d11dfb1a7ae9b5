"""Every registered level through the one factory: it resets, steps, and gives finite tensors of the declared shapes."""

from __future__ import annotations

import pytest
import torch
from conftest import composed

from mapush.levels import LEVELS, make_env
from mapush.rl.vecenv import AgentRowsVecEnv

E = 4


@pytest.mark.parametrize("level", sorted(LEVELS))
def test_a_level_resets_and_steps_with_finite_tensors_of_its_shapes(level, smoke_run):
    extra = [f"mid={smoke_run}"] if LEVELS[level].frozen_mid else []
    cfg = composed("debug=smoke", f"level={level}", *extra)
    cfg["num_envs"] = E
    env = make_env(cfg)
    rows, width = env.policy_agents, env.num_actions
    obs = env.observations()
    assert obs["policy"].shape[:2] == (E, rows) and obs["critic"].shape[0] == E
    gen = torch.Generator().manual_seed(0)
    for _ in range(5):
        actions = torch.rand(E, rows, width, generator=gen) * 2 - 1
        obs, reward, terminated, truncated, info = env.step(actions)
        assert obs["policy"].shape[:2] == (E, rows)
        assert reward.shape[0] == E and terminated.shape == truncated.shape == (E,)
        for tensor in (obs["policy"], obs["critic"], reward):
            assert torch.isfinite(tensor).all()
        assert "episode_end" in info
    vec = AgentRowsVecEnv(env)  # what rsl-rl sees: one row per env and policy agent
    assert vec.get_observations()["policy"].shape[0] == E * rows == vec.num_envs


def test_a_level_s_exceptions_are_its_config_terms():
    # every object tilts more than -1 rad, so object_tilt (third in conf/level/mid.yaml) fires at the first step
    cfg = composed("debug=smoke", "level.exceptions.object_tilt.params.max_rad=-1.0")
    cfg["num_envs"] = E
    env = make_env(cfg)
    assert env.exception_names == ("diverged", "robot_collision", "object_tilt", "robot_tilt")
    _, _, terminated, _, info = env.step(torch.zeros(E, env.num_agents, 3))
    assert terminated.all()
    assert info["episode_end"]["exception_kind"].tolist() == [2] * E


def test_a_level_s_observations_are_its_config_terms(smoke_run):
    # the H+L policy's view without its one-hot id: A = 2 numbers narrower, the critic's unchanged
    full = composed("debug=smoke", "level=high_nav")
    lean = composed("debug=smoke", "level=high_nav", "~level.observations.policy.one_hot")
    widths = []
    for cfg in (full, lean):
        cfg["num_envs"] = E
        obs = make_env(cfg).observations()
        widths.append((obs["policy"].shape[-1], obs["critic"].shape[-1]))
    assert widths[1] == (widths[0][0] - 2, widths[0][1])


def test_a_high_level_loads_its_frozen_mid_level_once_for_its_check_and_its_env(run_copy, monkeypatch):
    import mapush.levels as levels
    from mapush.config import compose_config

    loads = []
    real = levels.load_mid_policy
    monkeypatch.setattr(levels, "load_mid_policy", lambda *a, **k: loads.append(a[0]) or real(*a, **k))
    levels._frozen.cache_clear()
    plain = levels.checked(compose_config(["debug=smoke", "level=high", f"mid={run_copy}", "num_envs=2"]))
    env = levels.make_env(plain)
    assert loads == [str(run_copy.resolve())] and env.mid is levels.frozen_mid_level(plain)
    (run_copy / "model_9.pt").write_bytes((run_copy / "model_0.pt").read_bytes())  # the run goes on training
    assert levels.frozen_mid_level(plain) is not env.mid and len(loads) == 2
