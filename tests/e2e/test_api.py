"""The Python API (`mapush.make_env`, `mapush.load_policy`) and its gymnasium views (`mapush.VectorEnv`,
`mapush.SingleEnv`): shapes, spaces, seeding, autoreset, and gymnasium's own env checker."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest
import torch
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode

import mapush
from mapush.errors import BadInput

SMOKE = ["debug=smoke", "num_envs=3"]
SHORT = ["debug=smoke", "num_envs=2", "level.episode_length_s=0.1"]  # 5 steps of 0.02 s


@pytest.mark.slow
def test_make_env_and_load_policy_of_a_smoke_run_step_together(smoke_run):
    env = mapush.make_env(SMOKE)
    policy = mapush.load_policy(smoke_run)
    obs = env.observations()["policy"]
    assert obs.shape == (3, 2, 6 + 4 * (2 - 1)) == (3, 2, policy.obs_dim)  # README: 6 + 4 (A - 1)
    actions = policy.actor(obs.flatten(0, 1))  # no inference_mode needed: the weights need no gradient
    assert actions.shape == (6, policy.action_dim) == (6, env.num_actions)
    assert not actions.requires_grad and torch.isfinite(actions).all()
    obs, reward, terminated, truncated, _ = env.step(actions.view(3, 2, -1))
    assert obs["policy"].shape == (3, 2, 10)
    assert reward.shape == (3, 2) and terminated.shape == truncated.shape == (3,)
    assert policy.cfg["level"]["name"] == "mid" and policy.checkpoint.name.startswith("model_")


def test_make_env_of_an_unknown_task_is_the_cli_line():
    with pytest.raises(BadInput) as err:
        mapush.make_env(["task=nope"])
    assert (
        str(err.value)
        == "unknown task 'nope'; valid: cuboid, cylinder, ocb_cuboid, tblock (add yours with hydra.searchpath)"
    )


def test_make_env_checks_values_and_the_mid_level_before_building():
    with pytest.raises(BadInput, match=r"^num_envs=0 is not valid"):
        mapush.make_env(["num_envs=0"])
    with pytest.raises(BadInput, match=r"^level=high needs the frozen mid level"):
        mapush.make_env(["level=high", "debug=smoke"])


@pytest.mark.parametrize("level", ["mid", "high"])
@pytest.mark.slow
def test_the_vector_views_spaces_hold_what_reset_and_step_return(level, smoke_run):
    overrides = SMOKE if level == "mid" else [*SMOKE, "level=high", f"mid={smoke_run}"]
    env = mapush.VectorEnv(mapush.make_env(overrides))
    rows, width = (2, 3) if level == "mid" else (1, 2)  # every robot a row; the high level one decision per team
    assert env.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert env.num_envs == 3 and env.single_action_space.shape == (rows, width)
    assert env.action_space.shape == (3, rows, width) and env.observation_space.shape[:2] == (3, rows)
    obs, info = env.reset(seed=0)
    assert obs in env.observation_space and info == {}
    env.action_space.seed(0)
    for _ in range(3):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert obs in env.observation_space
        assert reward.shape == terminated.shape == truncated.shape == (3,)
        assert terminated.dtype == truncated.dtype == np.bool_
        assert info["agent_rewards"].shape == (3, rows)
    env.close()


def test_the_vector_reward_is_the_mean_of_the_agents_rewards():
    """The view and a bare env of the same config (same seed) stepped with the same actions stay in lockstep."""
    view, bare = mapush.VectorEnv(mapush.make_env(SMOKE)), mapush.make_env(SMOKE)
    rng = np.random.default_rng(0)
    for _ in range(5):
        actions = rng.uniform(-1, 1, (3, 2, 3)).astype(np.float32)
        obs, reward, terminated, _, info = view.step(actions)
        bare_obs, bare_reward, bare_terminated, _, _ = bare.step(torch.from_numpy(actions))
        np.testing.assert_array_equal(obs, bare_obs["policy"].numpy())
        np.testing.assert_array_equal(terminated, bare_terminated.numpy())
        np.testing.assert_array_equal(info["agent_rewards"], bare_reward.numpy())
        r = bare_reward.numpy()
        np.testing.assert_allclose(reward, (r[:, 0] + r[:, 1]) / 2, rtol=1e-6)  # two robots: (r0 + r1) / 2


def test_a_seeded_reset_repeats_its_observation():
    env = mapush.VectorEnv(mapush.make_env(SMOKE))
    first, _ = env.reset(seed=7)
    env.step(env.action_space.sample())
    again, _ = env.reset(seed=7)
    other, _ = env.reset(seed=8)
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)
    kept = again.copy()
    again += 1.0  # gymnasium callers keep what they get: changing it must not change the env
    np.testing.assert_array_equal(env.reset(seed=7)[0], kept)


def test_a_reset_mask_resets_only_those_envs():
    env = mapush.VectorEnv(mapush.make_env(SMOKE))
    before, _ = env.reset(seed=1)
    after, _ = env.reset(options={"reset_mask": np.array([False, True, False])})
    np.testing.assert_array_equal(after[[0, 2]], before[[0, 2]])
    assert not np.allclose(after[1], before[1])


def test_a_finished_episode_reports_its_last_observation_and_starts_the_next():
    """With zero actions the robots and the object stay still, so an episode's last observation is the one before
    it; the observation returned with the timeout is already the next episode's (SAME_STEP autoreset)."""
    env = mapush.VectorEnv(mapush.make_env(SHORT))
    obs, _ = env.reset(seed=0)
    still = np.zeros(env.action_space.shape, np.float32)
    for _ in range(4):
        previous = obs
        obs, _, terminated, truncated, info = env.step(still)
        assert not (terminated | truncated).any() and "final_obs" not in info
    obs, _, terminated, truncated, info = env.step(still)
    assert truncated.all() and not terminated.any() and info["_final_obs"].all()
    for i in range(2):
        np.testing.assert_allclose(info["final_obs"][i], previous[i], atol=1e-3)
        assert not np.allclose(obs[i], previous[i], atol=1e-2)
    np.testing.assert_allclose(info["final_info"]["time_s"], [0.1, 0.1])  # 5 steps x 0.02 s
    assert not info["final_info"]["success"].any() and info["final_info"]["_success"].all()


def test_check_env_passes_on_the_single_env_view():
    env = mapush.SingleEnv(mapush.make_env(["debug=smoke", "num_envs=1"]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    # observations are positions and velocities with no natural bound: gymnasium only warns about infinite bounds
    assert all("infinity" in str(w.message) for w in caught), [str(w.message) for w in caught]


def test_the_single_view_ends_an_episode_on_its_last_observation():
    env = mapush.SingleEnv(mapush.make_env([*SHORT, "num_envs=1"]))
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        previous = obs
        obs, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
    assert truncated and not terminated and isinstance(reward, float)
    np.testing.assert_allclose(obs, previous, atol=1e-3)
    assert info["time_s"] == pytest.approx(0.1) and not info["success"]


def test_the_single_view_needs_one_env():
    with pytest.raises(BadInput, match="num_envs=3"):
        mapush.SingleEnv(mapush.make_env(SMOKE))


def test_the_api_is_imported_on_first_use():
    code = (
        "import sys, mapush, mapush.config\n"
        "assert 'make_env' in dir(mapush) and not {'mapush.api', 'mapush.gym'} & set(sys.modules)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    from mapush import api, gym

    assert mapush.make_env is api.make_env and mapush.VectorEnv is gym.VectorEnv
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        mapush.nope  # noqa: B018
