"""The physics a finding needs, from the configs: an object's floor drag and one robot's push capacity.

A team is needed only where an object's drag exceeds what one robot pushes. The tables say which is the case beside
the single-agent baseline, with both numbers: the drag is mass x g x the task's friction range; the capacity is the
tracker's at the mid level's largest command, the lesser of its force cap and its velocity loop's stall force
(mass / lag x speed), which `mapush calibrate` fits to the legged Go1.
"""

from __future__ import annotations

import functools

from mapush.config import compose_config, to_plain

G = 9.81


def object_drag(task: str, overrides=(), mass: float | None = None) -> tuple[float, float]:
    """N; the least and greatest floor drag of the task's object: its mass (or `mass`, kg) x g x the friction
    range's ends."""
    own_mass, (low, high) = _object(task, tuple(overrides))
    mass = own_mass if mass is None else mass
    return mass * G * low, mass * G * high


def object_mass(task: str, overrides=()) -> float:
    """kg; the task's object's mass as composed (its `mass`, else its parts' own)."""
    return _object(task, tuple(overrides))[0]


@functools.cache  # the tables ask for each object's drag once per cell
def _object(task: str, overrides: tuple[str, ...]) -> tuple[float, tuple[float, float]]:
    """The task's object as composed: its mass (kg) and its floor friction range."""
    obj = to_plain(compose_config([f"task={task}", *overrides]))["task"]["object"]
    low, high = obj["friction"]
    return obj.get("mass") or sum(part["mass"] for part in obj["parts"]), (float(low), float(high))


def tracker_capacity(lowlevel: dict, speed: float) -> float:
    """N; the most one tracker pushes at a standstill when told `speed` (m/s): its velocity loop's stall force
    mass / lag x speed, capped at `max_force` (on the planar norm; a push straight along one axis under `axes`)."""
    return min(float(lowlevel["max_force"]), float(lowlevel["mass"]) / float(lowlevel["lag"]) * speed)


def one_robot_capacity(overrides=()) -> float | None:
    """N; one tracker's capacity at the mid level's largest command under `overrides`; None for a legged low level
    (its capacity is `mapush calibrate`'s measurement, results/calibration/)."""
    return _one_robot_capacity(tuple(overrides))


@functools.cache
def _one_robot_capacity(overrides: tuple[str, ...]) -> float | None:
    cfg = to_plain(compose_config(["level=mid", *overrides]))
    if cfg["lowlevel"]["name"] != "tracker":
        return None
    return tracker_capacity(cfg["lowlevel"], float(cfg["level"]["action_scale"][0]))


def team_needed(task: str, overrides=()) -> tuple[str, dict[str, float]]:
    """One line: the object's drag against one robot's capacity, and whether one robot can move it alone; and
    those numbers (N)."""
    low, high = object_drag(task, overrides)
    capacity = one_robot_capacity(overrides)
    numbers = {"drag_low_n": low, "drag_high_n": high}
    if capacity is None:
        return f"drag {low:.1f}-{high:.1f} N", numbers
    verdict = (
        "one robot cannot move it alone"
        if low > capacity
        else "one robot can move it alone"
        if high <= capacity
        else "one robot moves it only where the friction is low"
    )
    line = f"drag {low:.1f}-{high:.1f} N against one robot's capacity {capacity:.1f} N: {verdict}"
    return line, {**numbers, "capacity_n": capacity}
