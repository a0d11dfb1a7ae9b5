"""The hand-written H+L pusher (`NavHighPushEnv.scripted_goals`, the main table's "H+L, path only" column): a robot
behind the object walks on through it, any other robot to its staging slot, each goal within the action range."""

from __future__ import annotations

import torch
from stand_ins import stand_in_env

from mapush.envs.nav_high import NavHighPushEnv


def test_a_robot_behind_pushes_on_and_one_in_front_walks_around_to_the_staging_point():
    # object at the origin, pushed along +y (the path point ahead); the final target along +y too, so the target
    # frame's x axis is world +y and its y axis world -x
    env = stand_in_env(
        object_xy=torch.tensor([[0.0, 0.0]]),
        robot_xy=torch.tensor([[[0.0, -1.0], [0.0, 2.0]]]),  # robot 0 behind the object, robot 1 in front
        subgoal_xy=torch.tensor([[0.0, 2.0]]),
        target_xy=torch.tensor([[0.0, 10.0]]),
        num_agents=2,
        cfg={"level": {"robot_goal_range_m": 1.5, "scripted": {"reach_m": 0.6, "behind_m": 1.4}}},
    )
    goals = NavHighPushEnv.scripted_goals(env)
    # robot 0: 2 m on along +y, clipped to the 1.5 m range: from (0, -1) to (0, 0.5)
    assert torch.allclose(goals[0, 0], torch.tensor([0.0, 0.5]), atol=1e-6)
    # robot 1: its staging slot is 1.4 m behind the object and 0.3 m to the side (u turned left = world -x): world
    # (-0.3, -1.4), 3.4 m back from (0, 2); the range clips the 3.4 to 1.5: (-0.3, 0.5)
    assert torch.allclose(goals[0, 1], torch.tensor([-0.3, 0.5]), atol=1e-6)
