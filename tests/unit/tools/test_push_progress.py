"""tools/push_progress.py's watcher: where a push leaves the object and how long robots stand ahead of it, checked
on hand-placed states."""

from __future__ import annotations

import importlib.util
from types import SimpleNamespace

import pytest
import torch
from paths import REPO

SPEC = importlib.util.spec_from_file_location("push_progress", REPO / "tools" / "push_progress.py")
push_progress = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(push_progress)


def _env(object_xy, robot_xy, success):
    """Two envs of two robots, each pushing toward a subgoal at (3, 0)."""
    state = SimpleNamespace(object_xy=torch.tensor(object_xy), robot_xy=torch.tensor(robot_xy))
    return SimpleNamespace(
        state=state, subgoal_xy=torch.tensor([[3.0, 0.0], [3.0, 0.0]]), success=torch.tensor(success),
        num_envs=2, num_agents=2,
    )  # fmt: skip


def test_a_push_that_drives_the_object_away_is_told_from_one_that_arrives():
    watch = push_progress.PushWatch()
    # step 1: both objects at the origin, 3 m from the subgoal; env 0's robots behind it (x < 0), env 1's one
    # behind and one ahead (x > 0, the subgoal's side)
    watch.capture(_env([[0.0, 0.0], [0.0, 0.0]], [[[-1.0, 0.5], [-1.0, -0.5]], [[-1.0, 0.0], [1.0, 0.0]]],
                       [False, False]), None, None, None, torch.tensor([False, False]))  # fmt: skip
    # step 2: env 0 reaches the subgoal, pushed from behind, and ends; env 1's object went 1 m the wrong way, both
    # robots now ahead
    watch.capture(_env([[2.5, 0.0], [-1.0, 0.0]], [[[1.5, 0.5], [1.5, -0.5]], [[0.0, 0.0], [0.5, 1.0]]],
                       [True, False]), None, None, None, torch.tensor([True, False]))  # fmt: skip
    # step 3: env 0 has ended (a new episode would start; not counted); env 1 times out 2 m the wrong way
    watch.capture(_env([[9.0, 9.0], [-2.0, 0.0]], [[[9.0, 9.0], [9.0, 9.0]], [[-1.0, 0.0], [-0.5, 1.0]]],
                       [False, False]), None, None, None, torch.tensor([False, True]))  # fmt: skip
    assert watch.start.tolist() == [3.0, 3.0]
    assert watch.last.tolist() == [0.5, 5.0]
    assert watch.succeeded.tolist() == [True, False]
    # env 0: its robots stay behind its object over its 2 steps; env 1: 1 + 2 + 2 robots ahead over 3 steps of 2
    assert (watch.ahead_steps / watch.robot_steps).tolist() == pytest.approx([0.0, 5 / 6])
