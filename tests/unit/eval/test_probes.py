"""`mapush probe`'s watchers (`mapush.eval.probes`), checked on hand-placed states: where a push leaves the object
and how long robots stand ahead of it (progress), how hard the commands drive the robots (commands), and where
robots fall and whether they get up (falls)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
import torch

from mapush.eval.probes import HISTORY_S, TUMBLE_S, CommandWatch, FallWatch, PushWatch, lead_signals


def _env(object_xy, robot_xy, success):
    """Two envs of two robots, each pushing toward a subgoal at (3, 0)."""
    state = SimpleNamespace(object_xy=torch.tensor(object_xy), robot_xy=torch.tensor(robot_xy))
    return SimpleNamespace(
        state=state, subgoal_xy=torch.tensor([[3.0, 0.0], [3.0, 0.0]]), success=torch.tensor(success),
        num_envs=2, num_agents=2,
    )  # fmt: skip


def test_a_push_that_drives_the_object_away_is_told_from_one_that_arrives():
    watch = PushWatch()
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


def test_command_figures_count_only_first_episodes_as_shares_of_the_action_scale():
    watch = CommandWatch([1.0, 0.5, 2.0])
    env = SimpleNamespace(num_envs=2, num_agents=1)
    # step 1: env 0 at full scale on vx, env 1 at half scale on every axis; env 1's episode ends
    watch.capture(env, torch.tensor([[[1.0, 0.0, 0.0]], [[0.5, 0.25, 1.0]]]), None, None, torch.tensor([False, True]))
    # step 2: env 0 turns back to zero; env 1 is in its second episode (not counted)
    watch.capture(env, torch.tensor([[[0.0, 0.0, 0.0]], [[1.0, 0.5, 2.0]]]), None, None, torch.tensor([False, False]))
    figures = watch.figures()  # over 3 robot-steps: env 0's two, env 1's first
    assert figures["mean_abs"] == pytest.approx([1.5 / 3, 0.5 / 3, 0.5 / 3])
    assert figures["saturated"] == pytest.approx([1 / 3, 0.0, 0.0])
    assert figures["mean_change"] == pytest.approx([1 / 3, 0.0, 0.0])  # env 0's step from 1 back to 0 on vx


def _tilted(tilt, time_s=1.0, vel=None):
    """Three envs of two robots in a row 1 m apart facing +x, the object at the origin, no obstacles; robot tilts
    (3, 2), world velocities (3, 2, 3) (still unless given); a step of 0.1 s."""
    robot_xy = torch.tensor([[[1.0, 0.0], [2.0, 0.0]]] * 3)
    state = SimpleNamespace(
        robot_tilt=torch.tensor(tilt), robot_xy=robot_xy, object_xy=torch.zeros(3, 2), robot_yaw=torch.zeros(3, 2),
        robot_vel=torch.zeros(3, 2, 3) if vel is None else vel, object_vel=torch.zeros(3, 3),
        robot_distance=(robot_xy.unsqueeze(2) - robot_xy.unsqueeze(1)).norm(dim=-1),
    )  # fmt: skip
    return SimpleNamespace(
        state=state, num_envs=3, num_agents=2, obstacles=torch.zeros(3, 0, 3), frame_dt=0.1,
        episode_time_s=torch.full((3,), time_s), mid=SimpleNamespace(action_scale=torch.tensor([0.5, 0.5, 0.5])),
    )  # fmt: skip


def test_a_fallen_robot_that_stands_again_is_told_from_one_that_stays_down():
    watch = FallWatch(max_tilt=0.8)
    still = torch.zeros(3, 2, 3)
    # step 1: env 0's robot 1 and env 1's robot 0 fall; env 2 ends its first episode upright
    watch.capture(_tilted([[0.1, 1.2], [1.5, 0.1], [0.1, 0.1]]), still, None, None, torch.tensor([False, False, True]))
    # step 2: env 0's fallen robot stands again; env 1's stays down; env 2's second episode falls (not counted)
    watch.capture(_tilted([[0.1, 0.2], [2.9, 0.1], [1.5, 0.1]], 2.0), still, None, None, torch.zeros(3, dtype=bool))
    assert [(f["time_s"], f["object_m"], f["teammate_m"]) for f in watch.falls] == [(1.0, 2.0, 1.0), (1.0, 1.0, 1.0)]
    assert watch.fallen.tolist() == [1, 0, -1]
    assert watch.got_up.tolist() == [True, False, False]


def test_lead_signals_read_motion_against_off_and_without_a_command():
    # robot 0 faces +y and is told 0.4 m/s ahead (+y in the world) but moves 0.2 m/s toward -y; robot 1 faces +x, is
    # told 0.05 m/s ahead (standing) and slides 0.3 m/s sideways (+y)
    state = SimpleNamespace(
        robot_yaw=torch.tensor([[math.pi / 2, 0.0]]),
        robot_vel=torch.tensor([[[0.0, -0.2, 0.0], [0.0, 0.3, 0.0]]]),
        object_vel=torch.tensor([[0.1, 0.0, -0.3]]),  # the object turning clockwise at 0.3 rad/s
    )
    signals = lead_signals(torch.tensor([[[0.4, 0.0, 0.0], [0.05, 0.0, 0.0]]]), state)
    assert signals["against_mps"][0].tolist() == pytest.approx([0.2, 0.0])
    assert signals["error_mps"][0].tolist() == pytest.approx([0.6, math.hypot(0.05, 0.3)])
    assert signals["moved_still_mps"][0].tolist() == pytest.approx([0.0, 0.3])
    assert signals["object_turn_rps"][0].tolist() == pytest.approx([0.3, 0.3])


def test_a_fall_reports_the_motion_before_its_tumble_not_during_it():
    watch = FallWatch(max_tilt=0.8)
    told = torch.tensor([[[0.4, 0.0, 0.0]] * 2] * 3)  # every robot told 0.4 m/s ahead (+x)
    back = torch.zeros(3, 2, 3)
    back[0, 1, 0] = -0.25  # env 0's robot 1 is driven back at 0.25 m/s
    watch.capture(_tilted([[0.1, 0.1]] * 3, vel=back), told, None, None, torch.zeros(3, dtype=bool))
    tumble = torch.zeros(3, 2, 3)
    tumble[0, 1, 0] = -2.0  # then, rolling over, it moves fast: the tumble, left out
    for _ in range(round(TUMBLE_S / 0.1) - 1):  # with the fall's own step, TUMBLE_S of tumble
        watch.capture(
            _tilted([[0.1, 0.5]] + [[0.1, 0.1]] * 2, vel=tumble), told, None, None, torch.zeros(3, dtype=bool)
        )
    watch.capture(_tilted([[0.1, 1.2]] + [[0.1, 0.1]] * 2, vel=tumble), told, None, None, torch.zeros(3, dtype=bool))
    (fall,) = watch.falls
    assert fall["against_mps"] == pytest.approx(0.25)
    assert fall["error_mps"] == pytest.approx(0.65)
    # every robot-step's trailing maximum, TUMBLE_S back, sees env 0's robot 1 driven back (its first step's 0.25)
    steps = round(TUMBLE_S / 0.1) + 1
    assert watch.robot_steps == 3 * 2 * steps
    assert watch.beyond["against_mps"].tolist() == [steps, steps, 0]


def test_a_fall_keeps_its_robots_commands_of_the_last_history_seconds():
    watch = FallWatch(max_tilt=0.8)
    steps = round(HISTORY_S / 0.1)
    for k in range(steps + 3):  # env 1's robot 0 falls at the last step; each step's vx is its index
        tilt = [[0.1, 0.1], [1.2 if k == steps + 2 else 0.1, 0.1], [0.1, 0.1]]
        commands = torch.zeros(3, 2, 3)
        commands[1, 0, 0] = float(k)
        watch.capture(_tilted(tilt), commands, None, None, torch.zeros(3, dtype=bool))
    (history,) = watch.histories
    assert history.shape == (steps, 3) and watch.dt == 0.1
    assert history[:, 0].tolist() == [float(k) for k in range(3, steps + 3)]  # oldest first, up to the fall
