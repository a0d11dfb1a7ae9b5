"""Each low-level (locomotion) reward term against a value worked out by hand, on a stand-in Go1 env of 2 envs;
every term returns one column per env, (E, 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.rewards import legged


def column(*values: float) -> np.ndarray:
    """The expected (E, 1) array."""
    return np.array(values, dtype=np.float32).reshape(-1, 1)


def test_lin_vel_tracking_is_a_gaussian_kernel_of_the_planar_error():
    # sigma 0.25. env 0: command (1, 0), velocity (0.5, 0): |e|^2 = 0.25 -> exp(-0.25 / 0.25) = exp(-1) = 0.36788;
    # its vertical velocity 0.3 is ignored. env 1: command (0.3, -0.2), velocity (0.3, -0.2): exp(0) = 1
    env = stand_in_env(
        commands=torch.tensor([[1.0, 0.0, 0.7], [0.3, -0.2, 0.0]]),
        lin_vel=torch.tensor([[0.5, 0.0, 0.3], [0.3, -0.2, 0.0]]),
    )
    value = legged.lin_vel_tracking(env, sigma=0.25)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(math.exp(-1.0), 1.0), abs=1e-6)


def test_lin_vel_tracking_adds_the_squared_errors_of_both_axes():
    # command (0.5, 0.5), velocity (0, -0.5): |e|^2 = 0.25 + 1 = 1.25; sigma 0.5 -> exp(-2.5) = 0.082085
    env = stand_in_env(commands=torch.tensor([[0.5, 0.5, 0.0]]), lin_vel=torch.tensor([[0.0, -0.5, 0.0]]))
    assert legged.lin_vel_tracking(env, sigma=0.5).numpy() == pytest.approx(column(math.exp(-2.5)), abs=1e-6)


def test_yaw_rate_tracking_is_a_gaussian_kernel_of_the_yaw_rate_error():
    # sigma 0.25. env 0: command 0.5, yaw rate 0 -> exp(-0.25 / 0.25) = exp(-1); the roll / pitch rates (2, 3)
    # are ignored. env 1: command -1, yaw rate 0 -> exp(-1 / 0.25) = exp(-4) = 0.018316
    env = stand_in_env(
        commands=torch.tensor([[0.0, 0.0, 0.5], [1.0, 1.0, -1.0]]),
        ang_vel=torch.tensor([[2.0, 3.0, 0.0], [0.0, 0.0, 0.0]]),
    )
    value = legged.yaw_rate_tracking(env, sigma=0.25)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(math.exp(-1.0), math.exp(-4.0)), abs=1e-6)


def test_vertical_velocity_is_the_squared_vertical_speed():
    # v_z 0.3 -> 0.09, v_z -0.2 -> 0.04; the planar velocity does not count
    env = stand_in_env(lin_vel=torch.tensor([[1.0, 1.0, 0.3], [0.0, 0.0, -0.2]]))
    value = legged.vertical_velocity(env)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(0.09, 0.04), abs=1e-6)


def test_roll_pitch_rate_is_the_squared_roll_and_pitch_rates():
    # (0.3, 0.4) -> 0.09 + 0.16 = 0.25, the yaw rate 5 ignored; (0, 0) -> 0 whatever the yaw rate
    env = stand_in_env(ang_vel=torch.tensor([[0.3, 0.4, 5.0], [0.0, 0.0, -2.0]]))
    value = legged.roll_pitch_rate(env)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(0.25, 0.0), abs=1e-6)


def test_tilt_is_sin_squared_of_the_tilt_angle():
    # pitched 60 deg: g = (sin 60, 0, -cos 60) -> sin^2 60 = 0.75; upright g = (0, 0, -1) -> 0
    a = math.radians(60.0)
    env = stand_in_env(gravity=torch.tensor([[math.sin(a), 0.0, -math.cos(a)], [0.0, 0.0, -1.0]]))
    value = legged.tilt(env)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(0.75, 0.0), abs=1e-6)


def test_tilt_adds_roll_and_pitch():
    # g = (0.3, 0.4, -sqrt(0.75)): 0.09 + 0.16 = 0.25 (a 30 deg lean along a diagonal)
    env = stand_in_env(gravity=torch.tensor([[0.3, 0.4, -math.sqrt(0.75)]]))
    assert legged.tilt(env).numpy() == pytest.approx(column(0.25), abs=1e-6)


def test_joint_torques_is_the_sum_of_squared_torques():
    # env 0: twelve torques of 1 N m -> 12; env 1: 3 and -4 N m, the rest 0 -> 9 + 16 = 25
    torques = torch.zeros(2, 12)
    torques[0] = 1.0
    torques[1, 2], torques[1, 7] = 3.0, -4.0
    value = legged.joint_torques(stand_in_env(torques=torques))
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(12.0, 25.0), abs=1e-5)


def test_action_rate_is_the_sum_of_squared_action_changes():
    # env 0: every action 0 -> 0.5: 12 x 0.25 = 3; env 1: unchanged -> 0; env 2: one joint 0.2 -> -0.3: 0.25
    last = torch.zeros(3, 12)
    last[1] = 0.7
    last[2, 4] = 0.2
    actions = last.clone()
    actions[0] = 0.5
    actions[2, 4] = -0.3
    value = legged.action_rate(stand_in_env(actions=actions, last_actions=last))
    assert value.shape == (3, 1)
    assert value.numpy() == pytest.approx(column(3.0, 0.0, 0.25), abs=1e-6)


def test_foot_slip_counts_only_the_feet_on_the_ground():
    # env 0: speeds (1, 2, 3, 4), feet 0 and 2 in contact -> 1 + 9 = 10 (the swinging feet at 2 and 4 m/s
    # do not count); env 1: every foot down at 0.5 m/s -> 4 x 0.25 = 1
    env = stand_in_env(
        feet_speed=torch.tensor([[1.0, 2.0, 3.0, 4.0], [0.5, 0.5, 0.5, 0.5]]),
        foot_contact=torch.tensor([[True, False, True, False], [True, True, True, True]]),
    )
    value = legged.foot_slip(env)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(10.0, 1.0), abs=1e-6)


def test_foot_slip_of_a_robot_in_the_air_is_zero():
    env = stand_in_env(feet_speed=torch.full((1, 4), 3.0), foot_contact=torch.zeros(1, 4, dtype=torch.bool))
    assert legged.foot_slip(env).numpy() == pytest.approx(column(0.0))


def air_time_env(commands, landed_air_time, first_contact):
    return stand_in_env(
        commands=torch.tensor(commands),
        landed_air_time=torch.tensor(landed_air_time),
        first_contact=torch.tensor(first_contact),
    )


def test_feet_air_time_sums_over_the_feet_landing_this_step():
    # target 0.5 s, command (1, 0) (moving). env 0: feet 0 and 2 land after 0.8 s and 0.3 s in the air:
    # (0.8 - 0.5) + (0.3 - 0.5) = 0.1; feet 1 and 3 do not land (their -0.5 is not paid).
    # env 1: foot 3 lands after 0.9 s -> 0.4
    env = air_time_env(
        [[1.0, 0.0, 0.0], [0.0, -0.6, 0.0]],
        [[0.8, 0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 0.9]],
        [[True, False, True, False], [False, False, False, True]],
    )
    value = legged.feet_air_time(env, target_s=0.5)
    assert value.shape == (2, 1)
    assert value.numpy() == pytest.approx(column(0.1, 0.4), abs=1e-6)


def test_feet_air_time_penalizes_short_steps():
    # one foot lands after 0.2 s: 0.2 - 0.5 = -0.3
    env = air_time_env([[0.5, 0.0, 0.0]], [[0.0, 0.2, 0.0, 0.0]], [[False, True, False, False]])
    assert legged.feet_air_time(env, target_s=0.5).numpy() == pytest.approx(column(-0.3), abs=1e-6)


def test_feet_air_time_is_zero_when_the_command_is_to_stand_still():
    # env 0: command (0.05, 0.05), |v| = 0.0707 <= 0.1: stand still, so the 0.8 s landing (+0.3) is not paid,
    # whatever the yaw rate command (0.8); env 1: (0.1, 0.05), |v| = 0.1118 > 0.1: moving, paid 0.3
    env = air_time_env(
        [[0.05, 0.05, 0.8], [0.1, 0.05, 0.0]],
        [[0.8, 0.0, 0.0, 0.0], [0.8, 0.0, 0.0, 0.0]],
        [[True, False, False, False], [True, False, False, False]],
    )
    assert legged.feet_air_time(env, target_s=0.5).numpy() == pytest.approx(column(0.0, 0.3), abs=1e-6)


def test_feet_air_time_without_landings_is_zero():
    env = air_time_env([[1.0, 0.0, 0.0]], [[0.0, 0.0, 0.0, 0.0]], [[False, False, False, False]])
    assert legged.feet_air_time(env, target_s=0.5).numpy() == pytest.approx(column(0.0))


def test_fall_is_one_on_the_step_the_robot_falls():
    value = legged.fall(stand_in_env(exception=torch.tensor([True, False])))
    assert value.shape == (2, 1)
    assert value.tolist() == [[1.0], [0.0]]
