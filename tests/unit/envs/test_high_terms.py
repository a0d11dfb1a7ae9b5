"""The high level's reward terms and its centralized observation against values worked out by hand, on stand-in envs.

The observation is checked in its target frame (origin at the object, x toward the final target): one env whose
target lies along world +y, so the frame turns the world by -90 deg, (x, y) -> (y, -x), and one whose target lies
along world +x, so the frame only moves the origin.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.envs.observations import high_obs_dim, high_observation
from mapush.errors import BadInput
from mapush.planning.paths import remaining_length
from mapush.rewards import terms


def team(**attrs) -> SimpleNamespace:
    """A high-level stand-in: one policy row (the team) per env."""
    return stand_in_env(policy_agents=1, **attrs)


# ---------------------------------------------------------------------------------------------------------------
# reward terms, each (E, 1)


def test_target_reached_is_one_in_the_envs_that_succeeded():
    env = team(num_envs=3, success=torch.tensor([True, False, True]))
    assert terms.target_reached(env).tolist() == [[1.0], [0.0], [1.0]]


def test_target_approach_is_one_over_one_plus_the_target_distance():
    # d 0 -> 1; d 3 -> 1/4; d 0.5 -> 1/1.5 = 0.6667
    env = team(num_envs=3, target_distance=torch.tensor([0.0, 3.0, 0.5]))
    assert terms.target_approach(env).numpy() == pytest.approx(np.array([[1.0], [0.25], [2 / 3]]), abs=1e-6)


PATHS = torch.tensor(
    [
        [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],  # env 0: along x
        [[0.0, 0.0], [0.0, 2.0], [0.0, 4.0]],  # env 1: along y
    ]
)


def test_path_following_of_the_subgoal():
    # env 0: subgoal (1, 0.5) is 0.5 from path point (1, 0) -> 1 / 1.5 = 0.6667
    # env 1: subgoal (3, 4) is 3 from path point (0, 4) -> 1 / 4 = 0.25
    env = team(num_envs=2, path=PATHS, subgoal_xy=torch.tensor([[1.0, 0.5], [3.0, 4.0]]))
    expected = np.array([[2 / 3], [0.25]])
    assert terms.path_following(env, point="subgoal").numpy() == pytest.approx(expected, abs=1e-6)
    assert terms.path_following(env).numpy() == pytest.approx(expected, abs=1e-6)  # the default point


def test_path_following_measures_to_the_sampled_points_not_the_segments():
    # subgoal (1.5, 0) lies on env 0's path between the points (1, 0) and (2, 0), 0.5 from each: 1 / 1.5
    env = team(num_envs=1, path=PATHS[:1], subgoal_xy=torch.tensor([[1.5, 0.0]]))
    assert terms.path_following(env).item() == pytest.approx(2 / 3, abs=1e-6)


def test_path_following_of_the_object():
    # object at (2, 1): 1 from (2, 0) -> 0.5; object at (0, 1): 1 from (0, 0) and (0, 2) -> 0.5; the subgoals
    # (far from both paths) are not looked at
    env = team(
        num_envs=2,
        path=PATHS,
        object_xy=torch.tensor([[2.0, 1.0], [0.0, 1.0]]),
        subgoal_xy=torch.tensor([[50.0, 50.0], [50.0, 50.0]]),
    )
    assert terms.path_following(env, point="object").numpy() == pytest.approx(np.array([[0.5], [0.5]]), abs=1e-6)


def test_path_following_rejects_an_unknown_point():
    env = team(num_envs=1, path=PATHS[:1], subgoal_xy=torch.zeros(1, 2))
    with pytest.raises(BadInput, match="robot"):
        terms.path_following(env, point="robot")


def test_remaining_path_length_agrees_with_shapely():
    """Length minus shapely's projection (the arc length to the nearest point of the line) is what is left."""
    import shapely

    rng = np.random.default_rng(1)
    paths = torch.from_numpy(np.cumsum(rng.uniform(-1, 2, (50, 12, 2)), axis=1)).float()
    points = paths[:, 5] + torch.from_numpy(rng.uniform(-1.5, 1.5, (50, 2))).float()
    got = remaining_length(paths, points)
    for k in range(50):
        line = shapely.LineString(paths[k].tolist())
        expected = line.length - line.project(shapely.Point(points[k].tolist()))
        assert got[k].item() == pytest.approx(expected, abs=1e-3)


def test_path_progress_pays_alpha_times_the_drop_of_the_remaining_length_less_what_remains():
    path = torch.tensor([[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]]).repeat(3, 1, 1)  # 8 m
    start = torch.tensor([7.0, 4.0, 4.0])  # remaining at the decision's start: 7, 4 and 4 m
    now = torch.tensor([[2.0, 0.5], [4.0, 1.0], [3.9, -0.2]])  # 6, 3 and 4.1 m remain (the last off the path, back)
    env = stand_in_env(object_xy=now, path=path, path_remaining_at_decision=start, policy_agents=1)
    # 8 x 1 - 6, 8 x 1 - 3, 8 x (-0.1) - 4.1
    assert terms.path_progress(env, alpha=8.0)[:, 0].tolist() == pytest.approx([2.0, 5.0, -4.9], abs=1e-5)


def test_obstacle_proximity_is_one_over_one_plus_the_nearest_gap():
    # env 0: gaps (2, 0.5, 3) -> nearest 0.5 -> 1 / 1.5; env 1: overlapping (-0.1) counts as touching -> 1 / 1;
    # env 2: no obstacles (+inf) -> 1 / inf = 0
    gaps = torch.tensor([[2.0, 0.5, 3.0], [-0.1, 4.0, 4.0], [math.inf, math.inf, math.inf]])
    env = team(num_envs=3, object_obstacle_gap=gaps)
    assert terms.obstacle_proximity(env).numpy() == pytest.approx(np.array([[2 / 3], [1.0], [0.0]]), abs=1e-6)


# ---------------------------------------------------------------------------------------------------------------
# high_observation: layout 8 + 4 A + 2 L + 3 M (A = 2 robots, L = 2 path points, M = 3 obstacle slots): 29

OBSERVE = {"path_ahead_m": [1.0, 2.0], "obstacles": 3}
HALF_PI = math.pi / 2
SLICES = {
    "target_distance": slice(0, 1),
    "object_yaw": slice(1, 3),
    "object_vel": slice(3, 5),
    "subgoal": slice(5, 7),
    "robot_xy": slice(7, 11),
    "robot_yaw": slice(11, 15),
    "path_ahead": slice(15, 19),
    "obstacles": slice(19, 28),
    "time": slice(28, 29),
}


def observed_env(observe=OBSERVE, num_obstacles: int = 2, obstacles=None) -> SimpleNamespace:
    """Env 0: object at (1, 1) with yaw pi, target (1, 11): the frame's x axis is world +y.
    Env 1: object at the origin with yaw 0, target (12, 0): the frame's x axis is world +x."""
    if obstacles is None:
        obstacles = torch.tensor(
            [
                [[1.0, 5.0, 0.0, 2.0, 2.0], [4.0, 1.0, HALF_PI, 4.0, 1.0]],
                [[30.0, 0.0, 0.0, 2.0, 2.0], [0.0, -3.0, 0.0, 1.0, 1.0]],  # far; near
            ]
        )
    ahead = torch.tensor([[[1.0, 2.0], [2.0, 3.0]], [[1.0, 0.0], [2.0, 0.0]]])
    asked = []

    def path_points_ahead(distances: torch.Tensor) -> torch.Tensor:
        asked.append(distances.tolist())
        return ahead

    return stand_in_env(
        cfg={"level": {"observe": observe}, "task": {"num_agents": 2}},
        num_envs=2,
        num_agents=2,
        object_xy=torch.tensor([[1.0, 1.0], [0.0, 0.0]]),
        object_yaw=torch.tensor([math.pi, 0.0]),
        object_vel=torch.tensor([[0.3, 0.4, 9.0], [0.3, 0.4, 9.0]]),
        target_xy=torch.tensor([[1.0, 11.0], [12.0, 0.0]]),
        target_distance=torch.tensor([10.0, 12.0]),
        subgoal_xy=torch.tensor([[1.0, 3.0], [2.0, 0.0]]),
        robot_xy=torch.tensor([[[2.0, 1.0], [0.0, 0.0]], [[-1.0, 0.0], [0.0, -1.0]]]),
        robot_yaw=torch.tensor([[HALF_PI, 0.0], [0.0, HALF_PI]]),
        path_points_ahead=path_points_ahead,
        asked=asked,
        num_obstacles=num_obstacles,
        obstacles=obstacles,
        episode_step=torch.tensor([30, 60]),
        max_episode_length=120,
    )


def part(obs: torch.Tensor, name: str) -> np.ndarray:
    return obs[:, SLICES[name]].numpy()


def test_high_observation_width():
    # 8 + 4 x 2 + 2 x 2 + 3 x 3 = 29
    obs = high_observation(observed_env())
    assert obs.shape == (2, 29)
    assert high_obs_dim(observed_env().cfg) == 29


def test_target_distance_object_yaw_and_velocity_in_the_target_frame():
    # distance: as the env keeps it (10, 12). object yaw - heading: pi - pi/2 = pi/2 -> (0, 1); 0 - 0 -> (1, 0).
    # velocity (0.3, 0.4) -> env 0 (y, -x) = (0.4, -0.3), env 1 unchanged; the yaw rate 9 is not observed
    obs = high_observation(observed_env())
    assert part(obs, "target_distance") == pytest.approx(np.array([[10.0], [12.0]]), abs=1e-6)
    assert part(obs, "object_yaw") == pytest.approx(np.array([[0.0, 1.0], [1.0, 0.0]]), abs=1e-6)
    assert part(obs, "object_vel") == pytest.approx(np.array([[0.4, -0.3], [0.3, 0.4]]), abs=1e-6)


def test_subgoal_and_robots_in_the_target_frame():
    # env 0, relative to the object (1, 1), then (x, y) -> (y, -x):
    #   subgoal (1, 3): (0, 2) -> (2, 0); robot 0 (2, 1): (1, 0) -> (0, -1); robot 1 (0, 0): (-1, -1) -> (-1, 1)
    #   robot yaws - pi/2: 0 -> (1, 0); -pi/2 -> (0, -1)
    # env 1, relative to the origin: subgoal (2, 0); robots (-1, 0), (0, -1); yaws 0 -> (1, 0), pi/2 -> (0, 1)
    obs = high_observation(observed_env())
    assert part(obs, "subgoal") == pytest.approx(np.array([[2.0, 0.0], [2.0, 0.0]]), abs=1e-6)
    assert part(obs, "robot_xy") == pytest.approx(np.array([[0, -1, -1, 1], [-1, 0, 0, -1]]), abs=1e-6)
    assert part(obs, "robot_yaw") == pytest.approx(np.array([[1, 0, 0, -1], [1, 0, 0, 1]]), abs=1e-6)


def test_path_points_ahead_are_asked_at_the_configured_distances_and_turned_into_the_frame():
    # env 0: (1, 2) - (1, 1) = (0, 1) -> (1, 0); (2, 3) - (1, 1) = (1, 2) -> (2, -1). env 1: (1, 0), (2, 0)
    env = observed_env()
    obs = high_observation(env)
    assert env.asked == [[1.0, 2.0]]
    assert part(obs, "path_ahead") == pytest.approx(np.array([[1, 0, 2, -1], [1, 0, 2, 0]]), abs=1e-6)


def test_nearest_obstacles_nearest_first_with_padding_for_the_empty_slot():
    # env 0 (object (1, 1)):
    #   block A at (1, 5), 2 x 2: the object is (0, 4) from its centre, 4 - 1 = 3 m from its footprint;
    #     centre (0, 4) -> frame (4, 0)
    #   block B at (4, 1), yaw pi/2, 4 x 1 (in the world 1 wide in x, 4 in y): (-3, 0) from its centre,
    #     3 - 0.5 = 2.5 m; centre (3, 0) -> frame (0, -3)
    #   nearest first: B (0, -3, 2.5), A (4, 0, 3), then the third slot is padding (-20, 0, 20)
    # env 1 (object at the origin, frame = world):
    #   block at (0, -3), 1 x 1: 3 - 0.5 = 2.5 m, centre (0, -3): (0, -3, 2.5)
    #   block at (30, 0), 2 x 2: 29 m; its centre (30, 0) and distance clamp to 20: (20, 0, 20); then padding
    obs = high_observation(observed_env())
    expected = np.array([[0, -3, 2.5, 4, 0, 3, -20, 0, 20], [0, -3, 2.5, 20, 0, 20, -20, 0, 20]])
    assert part(obs, "obstacles") == pytest.approx(expected, abs=1e-5)


def test_time_fraction_is_the_last_element():
    # 30 / 120 = 0.25, 60 / 120 = 0.5
    obs = high_observation(observed_env())
    assert part(obs, "time") == pytest.approx(np.array([[0.25], [0.5]]), abs=1e-6)


def test_a_level_without_obstacles_fills_every_slot_with_padding():
    # no blocks at all: 3 slots of (-20, 0, 20); width 8 + 8 + 4 + 9 = 29 as before
    obs = high_observation(observed_env(num_obstacles=0, obstacles=torch.zeros(2, 0, 5)))
    assert obs.shape == (2, 29)
    assert part(obs, "obstacles") == pytest.approx(np.tile([-20.0, 0.0, 20.0], (2, 3)), abs=1e-6)
    assert part(obs, "time") == pytest.approx(np.array([[0.25], [0.5]]), abs=1e-6)


def test_more_obstacles_than_slots_keeps_only_the_nearest():
    # one slot, env 0: B (2.5 m) is nearer than A (3 m); env 1: the block at (0, -3) (2.5 m) beats the far one.
    # Width 8 + 8 + 4 + 3 = 23, the time fraction last
    obs = high_observation(observed_env(observe={"path_ahead_m": [1.0, 2.0], "obstacles": 1}))
    assert obs.shape == (2, 23)
    assert obs[:, 19:22].numpy() == pytest.approx(np.array([[0, -3, 2.5], [0, -3, 2.5]]), abs=1e-5)
    assert obs[:, 22].numpy() == pytest.approx(np.array([0.25, 0.5]), abs=1e-6)


def test_no_obstacle_slots_leave_the_obstacles_out():
    # width 8 + 8 + 4 + 0 = 20: the path points, then the time fraction
    obs = high_observation(observed_env(observe={"path_ahead_m": [1.0, 2.0], "obstacles": 0}))
    assert obs.shape == (2, 20)
    assert obs[:, 15:19].numpy() == pytest.approx(np.array([[1, 0, 2, -1], [1, 0, 2, 0]]), abs=1e-6)
    assert obs[:, 19].numpy() == pytest.approx(np.array([0.25, 0.5]), abs=1e-6)
