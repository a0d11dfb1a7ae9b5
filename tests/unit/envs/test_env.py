"""MidPushEnv: shapes, auto-reset of finished envs only, rewards before the reset, timeouts as truncations."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from mapush.rewards import terms

ZERO = torch.zeros(4, 2, 3)  # 4 envs x 2 agents, standing still
RANGES = "{lag:[0.1,0.45],yaw_lag:[0.02,0.4],max_force:[20,45]}"  # robot dynamics drawn in training (tried 2026-11-26)


@pytest.fixture
def env(make_env):
    """Smoke config: cuboid, 2 agents, 4 envs, 1 s episodes = 50 steps of 0.02 s."""
    return make_env("debug=smoke", num_envs=4)


def toward_object(obs: dict, num_envs: int, num_agents: int) -> torch.Tensor:
    """Actions driving each robot at full speed toward the object (policy obs 2:4 = object xy in its frame)."""
    to_object = obs["policy"][..., 2:4]
    actions = torch.zeros(num_envs, num_agents, 3)
    actions[..., :2] = to_object / torch.linalg.vector_norm(to_object, dim=-1, keepdim=True)
    return actions


def test_policy_step_is_20_ms_and_smoke_episodes_are_50_steps(env):
    # timestep 0.005 s x decimation 4 = 0.02 s; 1.0 s / 0.02 s = 50
    assert env.dt == pytest.approx(0.02)
    assert env.max_episode_length == 50


@pytest.mark.parametrize("num_agents", [1, 2, 3])
def test_step_shapes(make_env, num_agents):
    env = make_env("debug=smoke", f"task.num_agents={num_agents}", num_envs=3)
    obs, reward, terminated, truncated, info = env.step(torch.zeros(3, num_agents, 3))
    assert obs["policy"].shape == (3, num_agents, 6 + 4 * (num_agents - 1))
    assert obs["critic"].shape == (3, num_agents, 10 + 8 * num_agents)
    assert reward.shape == (3, num_agents)
    assert terminated.shape == truncated.shape == (3,)
    assert set(info) == {"episode_end", "log"}


def test_observations_and_rewards_are_finite_while_pushing(env):
    obs = env.observations()
    for _ in range(20):
        obs, reward, *_ = env.step(toward_object(obs, 4, 2))
        assert torch.isfinite(obs["policy"]).all()
        assert torch.isfinite(obs["critic"]).all()
        assert torch.isfinite(reward).all()


def _drive_forward(env, steps: int) -> torch.Tensor:
    """Each robot's distance covered in `steps` policy steps of full forward command, (E, A)."""
    start = env.state.robot_xy.clone()
    actions = torch.zeros(env.num_envs, env.num_agents, 3)
    actions[..., 0] = 1.0
    for _ in range(steps):
        env.step(actions)
    return torch.linalg.vector_norm(env.state.robot_xy - start, dim=-1)


def test_commands_move_the_calibrated_robots_of_an_evaluation_env_at_the_scaled_speed():
    from conftest import composed

    from mapush.envs.mid import MidPushEnv

    # action 1 is scaled to 0.5 m/s; with the tracker's first-order lag T the robot covers 0.5 (0.4 - T (1 - e^-0.4/T))
    # in 20 steps (0.4 s) of full forward command (the median: a robot may bump into the object), in training
    # (the default draws no robot dynamics) and in an evaluation env even where training draws them
    cfg = composed("debug=smoke")
    lag = cfg["lowlevel"]["lag"]
    expected = 0.5 * (0.4 - lag * (1 - math.exp(-0.4 / lag)))
    assert _drive_forward(MidPushEnv(cfg, num_envs=4), 20).median().item() == pytest.approx(expected, abs=0.005)
    varied = composed("debug=smoke", f"lowlevel.randomize={RANGES}")
    moved = _drive_forward(MidPushEnv(varied, num_envs=4, evaluation=True), 20)
    assert moved.median().item() == pytest.approx(expected, abs=0.005)


def test_a_training_env_drives_its_robots_with_the_drawn_dynamics():
    from conftest import composed

    from mapush.envs.mid import MidPushEnv

    # lag 0.4 s: 0.5 (0.4 - T (1 - e^-0.4/T)) m in 0.4 s, as above
    cfg = composed("debug=smoke", "lowlevel.randomize={lag:[0.4,0.4]}")
    expected = 0.5 * (0.4 - 0.4 * (1 - math.exp(-1.0)))
    assert _drive_forward(MidPushEnv(cfg, num_envs=4), 20).median().item() == pytest.approx(expected, abs=0.005)
    # a 6 N force limit on 12 kg: 0.5 m/s^2 while far below the commanded 0.5 m/s, so 0.1 m/s more in 0.2 s
    env = MidPushEnv(composed("debug=smoke", "lowlevel.randomize={max_force:[6,6]}"), num_envs=4)
    _drive_forward(env, 10)
    before = torch.linalg.vector_norm(env.state.robot_vel[..., :2], dim=-1)  # world frame: the speed
    _drive_forward(env, 10)
    gained = torch.linalg.vector_norm(env.state.robot_vel[..., :2], dim=-1) - before
    assert gained.median().item() == pytest.approx(0.1, abs=0.005)


def test_robot_dynamics_are_drawn_per_robot_from_the_ranges_and_anew_for_each_episode(make_env):
    env = make_env("debug=smoke", f"lowlevel.randomize={RANGES}")
    mass, idx = env.cfg["lowlevel"]["mass"], env.lowlevel.ctrl_idx  # (A, 3) actuator ids: x, y, yaw

    def drawn() -> tuple[torch.Tensor, torch.Tensor]:
        gain = torch.as_tensor(env.sim.batch.expand("actuator_gainprm")[:, idx, 0])  # (E, A, 3)
        force = torch.as_tensor(env.lowlevel.cap)  # (E, A) each robot's planar cap, N
        return mass / gain[..., 0], force

    lag, force = drawn()
    assert ((lag >= 0.1 - 1e-9) & (lag <= 0.45 + 1e-9)).all() and ((force >= 20) & (force <= 45)).all()
    assert len(set(lag.flatten().tolist())) == lag.numel()  # one draw per robot
    env.reset(np.array([1]))
    lag_after, _ = drawn()
    assert (lag_after[1] != lag[1]).all() and torch.equal(lag_after[[0, 2, 3]], lag[[0, 2, 3]])


def test_actions_are_clipped_to_one(make_env):
    fast, clipped = make_env("debug=smoke", num_envs=2), make_env("debug=smoke", num_envs=2)
    for _ in range(5):
        fast.step(torch.full((2, 2, 3), 5.0))
        clipped.step(torch.full((2, 2, 3), 1.0))
    assert torch.equal(fast.state.robot_xy, clipped.state.robot_xy)


def test_an_action_gain_scales_raw_actions_before_the_clip(make_env):
    # the original's chain, 0.5 clip(0.5 a): raw 1.2 drives as 0.6 does at gain 1, raw 4 as full scale
    halved, plain = make_env("debug=smoke", "level.action_gain=0.5", num_envs=2), make_env("debug=smoke", num_envs=2)
    for raw, as_plain in ((1.2, 0.6), (4.0, 1.0)):
        for _ in range(5):
            halved.step(torch.full((2, 2, 3), raw))
            plain.step(torch.full((2, 2, 3), as_plain))
        assert torch.equal(halved.state.robot_xy, plain.state.robot_xy)


def test_auto_reset_restarts_only_the_env_that_finished(env):
    env.step(ZERO)
    env.subgoal_xy[1] = env.state.object_xy[1]  # env 1 reaches its subgoal on the next step
    _, _, terminated, truncated, info = env.step(ZERO)
    assert terminated.tolist() == [False, True, False, False]
    assert truncated.tolist() == [False, False, False, False]
    assert info["episode_end"]["success"].tolist() == [False, True, False, False]
    assert env.episode_step.tolist() == [2, 0, 2, 2]


def test_reset_draws_a_new_subgoal_for_the_finished_env(env):
    env.step(ZERO)
    env.subgoal_xy[1] = env.state.object_xy[1]
    others = env.subgoal_xy[[0, 2, 3]].clone()
    env.step(ZERO)
    d = torch.linalg.vector_norm(env.subgoal_xy[1] - env.state.object_xy[1]).item()
    assert 1.5 - 1e-4 <= d <= 3.0 + 1e-4  # a fresh subgoal 1.5-3 m away
    assert torch.equal(env.subgoal_xy[[0, 2, 3]], others)


def test_reset_env_starts_from_a_fresh_layout_at_rest(env):
    obs = env.observations()
    for _ in range(10):
        obs, *_ = env.step(toward_object(obs, 4, 2))
    env.subgoal_xy[1] = env.state.object_xy[1]
    env.step(ZERO)
    ring = torch.linalg.vector_norm(env.state.robot_xy[1] - env.state.object_xy[1], dim=-1)
    assert env.state.object_xy[1].tolist() == pytest.approx([0.0, 0.0], abs=1e-6)  # the cuboid's start
    assert ((ring >= 1.2 - 1e-4) & (ring <= 1.3 + 1e-4)).all()  # robots back on the 1.2-1.3 m ring
    assert env.state.robot_vel[1].abs().max().item() < 1e-6


def test_object_friction_is_drawn_per_env_from_the_task_range(env):
    # cuboid: [0.3, 0.35] (the original's [0.5, 0.6] averaged with the 0.1 floor), one draw per env
    friction = torch.as_tensor(env.sim.geom_friction[:, env.sim.object_geoms, 0])
    assert friction.min().item() >= 0.3
    assert friction.max().item() <= 0.35
    assert len(set(friction[:, 0].tolist())) == 4


def test_reward_of_the_successful_step_is_computed_before_the_reset(env):
    # success pays subgoal_reached (weight 10) plus the progress of the jump: 3.25e-3 * 200 * d_prev = 0.65 d_prev
    # (d now ~0). After a reset progress would be -3.25e-3 * d_new instead. The other terms stay below 0.02 here.
    env.step(ZERO)
    d_prev = env.subgoal_distance[1].item()
    env.subgoal_xy[1] = env.state.object_xy[1]
    _, reward, *_ = env.step(ZERO)
    assert reward[1].tolist() == pytest.approx([10 + 0.65 * d_prev] * 2, abs=0.05)
    assert reward[[0, 2, 3]].abs().max().item() < 1.0


def test_success_is_logged_for_the_episode_that_ended(env):
    env.step(ZERO)
    env.subgoal_xy[1] = env.state.object_xy[1]
    _, _, _, _, info = env.step(ZERO)
    assert info["log"]["Metrics/success_rate"].item() == 1.0
    assert info["log"]["Reward/subgoal_reached"].item() == pytest.approx(10.0)
    assert info["episode_end"]["time_s"][1].item() == pytest.approx(0.04)


def test_timeout_is_truncated_not_terminated(make_env):
    # 0.1 s / 0.02 s = 5 steps
    env = make_env("debug=smoke", "level.episode_length_s=0.1", num_envs=4)
    assert env.max_episode_length == 5
    for _ in range(4):
        _, _, terminated, truncated, _ = env.step(ZERO)
        assert not truncated.any() and not terminated.any()
    _, _, terminated, truncated, info = env.step(ZERO)
    assert truncated.tolist() == [True] * 4
    assert terminated.tolist() == [False] * 4
    assert info["episode_end"]["success"].tolist() == [False] * 4
    assert env.episode_step.tolist() == [0] * 4


def test_robots_whose_footprints_touch_end_the_episode_as_an_exception(env):
    # put robot 1 of env 2 on top of robot 0
    env.sim.qpos[2, env.lowlevel.qpos_idx[1, :2]] = env.sim.qpos[2, env.lowlevel.qpos_idx[0, :2]]
    _, reward, terminated, _, info = env.step(ZERO)
    assert terminated.tolist() == [False, False, True, False]
    assert info["episode_end"]["exception"].tolist() == [False, False, True, False]
    assert info["episode_end"]["success"].tolist() == [False] * 4
    assert reward[2].max().item() < -4.0  # exception weight -5
    assert info["episode_end"]["exception_kind"].tolist() == [-1, -1, env.exception_names.index("robot_collision"), -1]


def test_agent_proximity_in_the_env_uses_the_current_robot_positions(env):
    obs = env.observations()
    for _ in range(3):
        obs, *_ = env.step(toward_object(obs, 4, 2))
    d = torch.linalg.vector_norm(env.state.robot_xy[:, 0] - env.state.robot_xy[:, 1], dim=-1)
    expected = (1.0 / (0.02 + d / 3.0)).unsqueeze(1).expand(4, 2)
    assert torch.allclose(terms.agent_proximity(env), expected, atol=1e-3)


def test_same_seed_and_actions_give_the_same_trajectory(make_env):
    def trajectory(seed: int) -> dict[str, torch.Tensor]:
        env = make_env(f"seed={seed}", num_envs=2)
        obs = env.observations()
        for _ in range(30):  # long enough for the robots to reach and push the object
            obs, *_ = env.step(toward_object(obs, 2, 2))
        return {"object_xy": env.state.object_xy, "robot_xy": env.state.robot_xy, "subgoal_xy": env.subgoal_xy}

    first, again, other = trajectory(3), trajectory(3), trajectory(4)
    assert all(torch.equal(first[k], again[k]) for k in first)
    assert all(not torch.equal(first[k], other[k]) for k in first)


def test_episode_length_that_is_a_whole_number_of_steps_is_not_rounded_up(make_env):
    # 0.14 s / 0.02 s = 7 steps; float division gives 7.000000000000001
    env = make_env("debug=smoke", "level.episode_length_s=0.14", num_envs=2)
    assert env.max_episode_length == 7
