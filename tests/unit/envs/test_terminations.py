"""Exception terms (mapush/envs/terminations.py) on hand-placed stand-in states: each fires in one env and not in
another just on the other side of its threshold, so every test checks a per-env mix of flags."""

from __future__ import annotations

import math

import torch
from stand_ins import stand_in_env

from mapush.envs import terminations


def distances(*pairs: tuple[int, int, float], agents: int = 3) -> torch.Tensor:
    """A robot-centre distance matrix (A, A): the given (i, j, d) pairs, 5 m for the other pairs, diagonal 0."""
    d = torch.full((agents, agents), 5.0)
    d.fill_diagonal_(0.0)
    for i, j, value in pairs:
        d[i, j] = d[j, i] = value
    return d


# ---------------------------------------------------------------------------------------------------------------
# diverged, planner_failure: the flags the env sets, passed through


def test_diverged_returns_the_envs_flags_unchanged():
    env = stand_in_env(diverged=torch.tensor([False, True, False]))
    assert terminations.diverged(env).tolist() == [False, True, False]


def test_planner_failure_fires_only_where_the_plan_failed():
    env = stand_in_env(plan_failed=torch.tensor([True, False]))
    assert terminations.planner_failure(env).tolist() == [True, False]


# ---------------------------------------------------------------------------------------------------------------
# robot_collision


def test_robot_collision_fires_for_a_pair_closer_than_the_distance_in_that_env_only():
    # limit 0.5 m: env 0 has robots 1 and 2 at 0.49 m (< 0.5, fires); env 1's closest pair is 0.51 m (> 0.5)
    robot_distance = torch.stack([distances((1, 2, 0.49)), distances((0, 1, 0.51), (0, 2, 0.8))])
    env = stand_in_env(num_agents=3, robot_distance=robot_distance)
    assert terminations.robot_collision(env, distance_m=0.5).tolist() == [True, False]


def test_robot_collision_ignores_each_robots_zero_distance_to_itself():
    # the diagonal is 0 < 0.5 but is no pair; every real pair is 5 m apart; a lone robot has only its diagonal
    env = stand_in_env(num_agents=3, robot_distance=torch.stack([distances(), distances()]))
    assert terminations.robot_collision(env, distance_m=0.5).tolist() == [False, False]
    alone = stand_in_env(num_agents=1, robot_distance=torch.zeros(2, 1, 1))
    assert terminations.robot_collision(alone, distance_m=0.5).tolist() == [False, False]


# ---------------------------------------------------------------------------------------------------------------
# object_tilt, robot_tilt


def test_object_tilt_fires_beyond_the_limit():
    # limit 0.8 rad: 0.81 > 0.8 fires, 0.79 does not, and neither does an upright object (0)
    env = stand_in_env(object_tilt=torch.tensor([0.81, 0.79, 0.0]))
    assert terminations.object_tilt(env, max_rad=0.8).tolist() == [True, False, False]


def test_robot_tilt_fires_when_any_robot_of_the_env_is_beyond_the_limit():
    # limit 0.8 rad: env 0's robot 1 is at 0.81 (fires), env 1's robots are both at 0.79 (do not)
    env = stand_in_env(robot_tilt=torch.tensor([[0.1, 0.81], [0.79, 0.79]]))
    assert terminations.robot_tilt(env, max_rad=0.8).tolist() == [True, False]


# ---------------------------------------------------------------------------------------------------------------
# robot_hit_obstacle, object_hit_obstacle: gaps > 0 apart, <= 0 overlapping


def test_robot_hit_obstacle_fires_for_any_robot_within_the_tolerance_of_any_block():
    # tolerance 0.02 m; gaps (E=3, A=2, K=2): env 0 robot 1 is 0.019 m from block 1 (< 0.02: fires);
    # env 1 has every gap >= 0.021 (does not); env 2's robot 0 overlaps block 0 (gap -0.3 < 0.02: fires)
    gaps = torch.tensor(
        [
            [[1.0, 2.0], [3.0, 0.019]],
            [[0.021, 0.5], [0.03, 4.0]],
            [[-0.3, 2.0], [1.0, 1.0]],
        ]
    )
    env = stand_in_env(robot_obstacle_gap=gaps)
    assert terminations.robot_hit_obstacle(env, tolerance_m=0.02).tolist() == [True, False, True]


def test_robot_hit_obstacle_never_fires_without_obstacles():
    # a level without obstacles keeps the gaps at +inf (E, A, 1)
    env = stand_in_env(robot_obstacle_gap=torch.full((2, 3, 1), float("inf")))
    assert terminations.robot_hit_obstacle(env, tolerance_m=0.02).tolist() == [False, False]


def test_object_hit_obstacle_fires_for_any_block_within_the_tolerance():
    # tolerance 0.02 m; gaps (E=3, K=3): env 0 block 2 at 0.019 (fires), env 1 nearest 0.021 (does not),
    # env 2 overlapping block 0 (gap -0.1, fires)
    gaps = torch.tensor([[2.0, 1.0, 0.019], [0.021, 3.0, 0.5], [-0.1, 5.0, 5.0]])
    env = stand_in_env(object_obstacle_gap=gaps)
    assert terminations.object_hit_obstacle(env, tolerance_m=0.02).tolist() == [True, False, True]


def test_object_hit_obstacle_never_fires_without_obstacles():
    env = stand_in_env(object_obstacle_gap=torch.full((2, 1), float("inf")))
    assert terminations.object_hit_obstacle(env, tolerance_m=0.02).tolist() == [False, False]


# ---------------------------------------------------------------------------------------------------------------
# fall (the legged level): trunk origin too low, tilted too far, or the trunk box too near the ground

LIMITS = {"min_height_m": 0.15, "max_tilt": 1.0, "trunk_clearance_m": 0.02}
UPRIGHT = [0.0, 0.0, -1.0]  # body-frame gravity of an upright robot


def tilted(degrees: float) -> list[float]:
    """Body-frame gravity of a robot pitched by `degrees`: (sin a, 0, -cos a)."""
    a = math.radians(degrees)
    return [math.sin(a), 0.0, -math.cos(a)]


def go1(base_height, gravity, trunk_z, trunk_half_height: float = 0.05):
    return stand_in_env(
        base_height=torch.tensor(base_height),
        gravity=torch.tensor(gravity),
        trunk_z=torch.tensor(trunk_z),
        trunk_half_height=trunk_half_height,
    )


def test_fall_when_the_trunk_origin_is_below_the_minimum_height():
    # min 0.15 m: 0.14 falls, 0.16 stands (upright, trunk box bottom 0.3 - 0.05 = 0.25 m up)
    env = go1([0.14, 0.16], [UPRIGHT, UPRIGHT], [0.3, 0.3])
    assert terminations.fall(env, **LIMITS).tolist() == [True, False]


def test_fall_when_tilted_beyond_the_maximum():
    # max 1.0 rad = 57.3 deg: 60 deg = 1.047 rad falls, 55 deg = 0.960 rad stands; the tilt is arccos(-g_z),
    # whatever the direction of the lean (the 60 deg one leans sideways: g = (0, sin 60, -cos 60))
    a = math.radians(60.0)
    env = go1([0.3, 0.3, 0.3], [[0.0, math.sin(a), -math.cos(a)], tilted(55.0), tilted(60.0)], [0.3, 0.3, 0.3])
    assert terminations.fall(env, **LIMITS).tolist() == [True, False, True]


def test_fall_of_a_robot_on_its_back():
    # gravity along body +z: tilt arccos(-1) = pi > 1.0
    env = go1([0.3, 0.3], [[0.0, 0.0, 1.0], UPRIGHT], [0.3, 0.3])
    assert terminations.fall(env, **LIMITS).tolist() == [True, False]


def test_fall_when_the_trunk_box_bottom_is_within_the_clearance_of_the_ground():
    # half height 0.05, clearance 0.02: trunk centre 0.069 -> bottom 0.019 < 0.02 falls; 0.071 -> 0.021 stands
    env = go1([0.3, 0.3], [UPRIGHT, UPRIGHT], [0.069, 0.071])
    assert terminations.fall(env, **LIMITS).tolist() == [True, False]


def test_fall_uses_the_envs_trunk_half_height():
    # trunk centre 0.1 m: with half height 0.05 the bottom is 0.05 m up (stands), with 0.09 it is 0.01 m (falls)
    low_box = go1([0.3, 0.3], [UPRIGHT, UPRIGHT], [0.1, 0.1], trunk_half_height=0.05)
    tall_box = go1([0.3, 0.3], [UPRIGHT, UPRIGHT], [0.1, 0.1], trunk_half_height=0.09)
    assert terminations.fall(low_box, **LIMITS).tolist() == [False, False]
    assert terminations.fall(tall_box, **LIMITS).tolist() == [True, True]
