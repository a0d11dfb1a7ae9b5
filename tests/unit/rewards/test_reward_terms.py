"""Each mid-level reward term against a value worked out by hand, on a stand-in env (only the attributes it reads)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.rewards import terms


def stand_in(**attrs) -> SimpleNamespace:
    """An env with the given tensors; num_envs / num_agents from robot_xy (E, A, 2) when given, else 1 x 2.

    With robot_xy it also carries `robot_distance` (E, A, A), the robot-centre distances the env keeps.
    """
    robot_xy = attrs.get("robot_xy")
    if robot_xy is None:
        agents = attrs.pop("num_agents", 2)
        return stand_in_env(num_envs=attrs.pop("num_envs", 1), num_agents=agents, policy_agents=agents, **attrs)
    distance = torch.linalg.vector_norm(robot_xy.unsqueeze(2) - robot_xy.unsqueeze(1), dim=-1)
    E, A = robot_xy.shape[:2]
    return stand_in_env(num_envs=E, num_agents=A, policy_agents=A, robot_distance=distance, **attrs)


def test_subgoal_reached_is_one_for_every_agent_of_a_successful_env():
    env = stand_in(num_envs=2, num_agents=3, success=torch.tensor([True, False]))
    assert terms.subgoal_reached(env).tolist() == [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]


def test_subgoal_progress_rewards_the_distance_gained_minus_the_distance_left():
    # alpha 200, d 2.0 -> 1.9: 200 * 0.1 - 1.9 = 18.1
    env = stand_in(prev_subgoal_distance=torch.tensor([2.0]), subgoal_distance=torch.tensor([1.9]))
    assert terms.subgoal_progress(env, alpha=200.0).numpy() == pytest.approx(np.array([[18.1, 18.1]]), abs=1e-4)


def test_subgoal_progress_is_negative_when_the_object_moves_away():
    # d 1.0 -> 1.1: 200 * (-0.1) - 1.1 = -21.1
    env = stand_in(prev_subgoal_distance=torch.tensor([1.0]), subgoal_distance=torch.tensor([1.1]))
    assert terms.subgoal_progress(env, alpha=200.0).numpy() == pytest.approx(np.array([[-21.1, -21.1]]), abs=1e-4)


def test_exception_is_one_for_every_agent_of_an_env_that_failed():
    env = stand_in(num_envs=2, num_agents=2, exception=torch.tensor([False, True]))
    assert terms.exception(env).tolist() == [[0.0, 0.0], [1.0, 1.0]]


def test_agent_proximity_of_two_robots_1_5_m_apart():
    # 1 / (0.02 + 1.5 / 3) = 1 / 0.52 = 1.9231 for each robot
    env = stand_in(robot_xy=torch.tensor([[[0.0, 0.0], [1.5, 0.0]]]))
    assert terms.agent_proximity(env).numpy() == pytest.approx(np.array([[1.9231, 1.9231]]), abs=1e-3)


def test_agent_proximity_sums_over_the_other_robots():
    # robots at x = 0, 1.5, 3: ends 1/0.52 + 1/(0.02 + 1) = 1.9231 + 0.9804 = 2.9035, middle 2 / 0.52 = 3.8462
    env = stand_in(robot_xy=torch.tensor([[[0.0, 0.0], [1.5, 0.0], [3.0, 0.0]]]))
    assert terms.agent_proximity(env).numpy() == pytest.approx(np.array([[2.9035, 3.8462, 2.9035]]), abs=1e-3)


def test_agent_proximity_of_a_lone_robot_is_zero():
    env = stand_in(robot_xy=torch.tensor([[[4.0, -2.0]]]))
    assert terms.agent_proximity(env).numpy() == pytest.approx(np.array([[0.0]]), abs=1e-4)


def test_object_approach_at_one_metre():
    # -(1.0 + 0.5)^2 = -2.25; at the object's centre -(0 + 0.5)^2 = -0.25
    env = stand_in(robot_xy=torch.tensor([[[1.0, 2.0], [0.0, 2.0]]]), object_xy=torch.tensor([[0.0, 2.0]]))
    assert terms.object_approach(env).numpy() == pytest.approx(np.array([[-2.25, -0.25]]))


def test_object_approach_uses_the_planar_distance():
    # robot at (3, 4) from the object: d = 5 -> -(5.5)^2 = -30.25
    env = stand_in(robot_xy=torch.tensor([[[3.0, 4.0]]]), object_xy=torch.tensor([[0.0, 0.0]]))
    assert terms.object_approach(env).item() == pytest.approx(-30.25)


def test_object_moving_is_one_above_the_speed_threshold():
    # planar speed |(0.3, 0.4)| = 0.5 m/s
    env = stand_in(object_vel=torch.tensor([[0.3, 0.4, 0.0]]))
    assert terms.object_moving(env, min_speed=0.49).tolist() == [[1.0, 1.0]]
    assert terms.object_moving(env, min_speed=0.51).tolist() == [[0.0, 0.0]]


def test_object_moving_ignores_the_yaw_rate():
    env = stand_in(object_vel=torch.tensor([[0.0, 0.0, 5.0]]))
    assert terms.object_moving(env, min_speed=0.1).tolist() == [[0.0, 0.0]]


def test_robot_jam_marks_the_robots_body_to_body_while_the_object_stands():
    # robots 0 and 1 are 0.5 m apart, robot 2 is 3 m from both; env 0's object creeps at 0.01 m/s, env 1's at 0.3
    xy = torch.tensor([[[0.0, 0.0], [0.5, 0.0], [3.0, 0.0]]]).expand(2, 3, 2)
    env = stand_in(robot_xy=xy, object_vel=torch.tensor([[0.01, 0.0, 0.0], [0.3, 0.0, 0.0]]))
    assert terms.robot_jam(env, distance_m=0.8, max_speed=0.05).tolist() == [[1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]
    assert terms.robot_jam(env, distance_m=0.4, max_speed=0.05).tolist() == [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    assert terms.robot_jam(env, distance_m=0.8, max_speed=0.5).tolist() == [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]]
