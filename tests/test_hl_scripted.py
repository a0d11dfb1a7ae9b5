"""The hand-written H+L policy of tools/hl_scripted.py, whose success rates results/README.md holds against the
learned H+L cells: a robot behind the object walks on through it, any other robot to the staging point."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import torch
from stand_ins import stand_in_env

SPEC = importlib.util.spec_from_file_location("hl_scripted", Path(__file__).parents[1] / "tools" / "hl_scripted.py")
hl_scripted = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(hl_scripted)


def test_a_robot_behind_pushes_on_and_one_in_front_walks_around_to_the_staging_point():
    # object at the origin, pushed along +y (the path point ahead); the final target along +y too, so the target
    # frame's x axis is world +y and its y axis world -x
    env = stand_in_env(
        object_xy=torch.tensor([[0.0, 0.0]]),
        robot_xy=torch.tensor([[[0.0, -1.0], [0.0, 2.0]]]),  # robot 0 behind the object, robot 1 in front
        subgoal_xy=torch.tensor([[0.0, 2.0]]),
        target_xy=torch.tensor([[0.0, 10.0]]),
        num_agents=2,
        cfg={"level": {"robot_goal_range_m": 1.5}},
    )
    actions = hl_scripted.scripted_actions(env, reach=0.6, behind=1.4)
    # robot 0: 2 m on along +y = target-frame (2, 0), over the 1.5 m range and clipped: (1, 0)
    assert torch.allclose(actions[0, 0], torch.tensor([1.0, 0.0]), atol=1e-6)
    # robot 1: its staging slot is 1.4 m behind the object and +0.3 m to the side (side = u turned left = world
    # -x): world (-0.3, -1.4); from (0, 2) that is (-0.3, -3.4) in the world, (-3.4, 0.3) in the target frame,
    # over 1.5 and clipped: (-1, 0.2)
    assert torch.allclose(actions[0, 1], torch.tensor([-1.0, 0.3 / 1.5]), atol=1e-6)
    assert math.isclose(float(actions.abs().max()), 1.0)
