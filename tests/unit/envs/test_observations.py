"""Local (actor) and global (critic) observations: frames, layout and widths, on hand-placed stand-in states."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.envs.observations import global_dim, global_observation, local_dim, local_observation, to_agent_frame


def stand_in() -> SimpleNamespace:
    """1 env, 2 robots: robot 0 at (1, 0) facing +y (yaw pi/2), robot 1 at (0, -2) facing +x; object at the origin
    with yaw pi/2, subgoal at (0, 3), step 10 of 50."""
    return stand_in_env(
        num_envs=1,
        num_agents=2,
        robot_xy=torch.tensor([[[1.0, 0.0], [0.0, -2.0]]]),
        robot_yaw=torch.tensor([[math.pi / 2, 0.0]]),
        object_xy=torch.zeros(1, 2),
        object_yaw=torch.tensor([math.pi / 2]),
        object_vel=torch.tensor([[0.1, 0.2, 0.3]]),
        subgoal_xy=torch.tensor([[0.0, 3.0]]),
        robot_vel=torch.tensor([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]]),
        episode_step=torch.tensor([10]),
        max_episode_length=50,
        other_agents=torch.tensor([[1], [0]]),
        agent_one_hot=torch.eye(2).unsqueeze(0),
    )


def test_observation_widths():
    # local 6 + 4 (A - 1), global 10 + 8 A
    assert [local_dim(a) for a in (1, 2, 3, 4)] == [6, 10, 14, 18]
    assert [global_dim(a) for a in (1, 2, 3, 4)] == [18, 26, 34, 42]


def test_agent_frame_turns_the_world_into_the_robots_view():
    # robot at (1, 0) facing +y sees the origin 1 m to its left: (0, 1)
    seen = to_agent_frame(torch.zeros(1, 1, 2), torch.tensor([[[1.0, 0.0]]]), torch.tensor([[math.pi / 2]]))
    assert seen[0, 0].tolist() == pytest.approx([0.0, 1.0], abs=1e-6)


def test_local_observation_of_robot_0():
    # subgoal (0, 3) - (1, 0) = (-1, 3) -> in its frame (3, 1); object (-1, 0) -> (0, 1); object yaw - own yaw = 0;
    # robot 1 at (-1, -2) -> (-2, 1), its yaw - own yaw = -pi/2 -> (cos, sin) = (0, -1)
    obs = local_observation(stand_in())[0, 0]
    assert obs.numpy() == pytest.approx(np.array([3, 1, 0, 1, 1, 0, -2, 1, 0, -1]), abs=1e-6)


def test_local_observation_of_robot_1():
    # robot 1 at (0, -2) facing +x: subgoal (0, 5), object (0, 2), object yaw pi/2 -> (0, 1);
    # robot 0 at (1, 2), yaw + pi/2 -> (0, 1)
    obs = local_observation(stand_in())[0, 1]
    assert obs.numpy() == pytest.approx(np.array([0, 5, 0, 2, 0, 1, 1, 2, 0, 1]), abs=1e-6)


def test_global_observation_is_the_world_state_plus_the_agent_one_hot():
    # object xy | yaw (cos, sin) | vel | subgoal | robots xy | robots yaw | robots vel | 10 / 50 | one-hot
    obs = global_observation(stand_in())
    state = [0, 0, 0, 1, 0.1, 0.2, 0.3, 0, 3, 1, 0, 0, -2, 0, 1, 1, 0, 1, 2, 3, 4, 5, 6, 0.2]
    assert obs[0, 0].numpy() == pytest.approx(np.array([*state, 1, 0]), abs=1e-6)
    assert obs[0, 1].numpy() == pytest.approx(np.array([*state, 0, 1]), abs=1e-6)
