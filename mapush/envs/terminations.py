"""Exception terms (paper III-C: r_exception): each returns (E,) flags of the envs where it fires this step.

A level's `level.exceptions` names its terms in order; the first that fires names the exception
(`exception_kind`). Terms read the env's state after the physics step, before any reset.
"""

from __future__ import annotations

import torch

from mapush.planning.geometry import polygon_gap, rectangles


def diverged(env) -> torch.Tensor:
    """The simulation failed this step, or its state is no longer finite (the step sets `env.diverged`)."""
    return env.diverged


def robot_collision(env, distance_m: float) -> torch.Tensor:
    """Two robot centres closer than `distance_m`: the original's check, which runs made before 2026-11-28 name
    (the levels' `robot_collision` is `robot_contact` now)."""
    pair = env.state.robot_distance + torch.eye(env.num_agents) * 1e9
    return (pair < distance_m).flatten(1).any(-1)


def robot_contact(env, tolerance_m: float) -> torch.Tensor:
    """Two robots' footprints (`lowlevel.size`: length x width, at their poses) within `tolerance_m` of each
    other: robots that touch, the levels' `robot_collision`. Unlike the original's centre distance (0.25 m, which
    the tracker's 0.28 m-wide footprint never reaches), this can happen on every low level."""
    s = env.state
    length, width = env.cfg["lowlevel"]["size"][:2]
    boxes = rectangles(s.robot_xy, s.robot_yaw, length, width)  # (E, A, 4, 2)
    gap = polygon_gap(boxes.unsqueeze(2), boxes.unsqueeze(1))  # (E, A, A): separating-axis gap, <= the distance
    gap = gap + torch.eye(env.num_agents) * 1e9  # a robot does not touch itself
    return (gap < tolerance_m).flatten(1).any(-1)


def object_tilt(env, max_rad: float) -> torch.Tensor:
    """The object tilted further than `max_rad` from upright."""
    return env.state.object_tilt > max_rad


def object_height_change(env, max_m: float) -> torch.Tensor:
    """The object's centre more than `max_m` above or below its resting height: the original's `z_wave` on the
    object (0.35 m), which a lifted or toppled object trips."""
    return (env.state.object_z - env.sim.object_rest_z).abs() > max_m


def robot_tilt(env, max_rad: float) -> torch.Tensor:
    """A robot's roll or pitch beyond `max_rad` (a fall, for backends that can fall)."""
    return (env.state.robot_tilt > max_rad).any(-1)


def robot_hit_obstacle(env, tolerance_m: float) -> torch.Tensor:
    """A robot's footprint within `tolerance_m` of an obstacle block."""
    return (env.robot_obstacle_gap < tolerance_m).flatten(1).any(-1)


def object_hit_obstacle(env, tolerance_m: float) -> torch.Tensor:
    """The object's hull within `tolerance_m` of an obstacle block."""
    return (env.object_obstacle_gap < tolerance_m).any(-1)


def planner_failure(env) -> torch.Tensor:
    """OMPL found no valid path for this episode (its path is a straight line)."""
    return env.plan_failed


def fall(env, min_height_m: float, max_tilt: float, trunk_clearance_m: float) -> torch.Tensor:
    """A Go1 down: trunk origin below `min_height_m`, tilted beyond `max_tilt` rad, or its trunk box bottom closer
    than `trunk_clearance_m` to the ground."""
    s = env.state
    tilt = torch.arccos((-s.gravity[:, 2]).clamp(-1.0, 1.0))
    trunk_on_ground = s.trunk_z - env.trunk_half_height < trunk_clearance_m
    return (s.base_height < min_height_m) | (tilt > max_tilt) | trunk_on_ground
