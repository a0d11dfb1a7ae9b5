"""Whether a task's robots fit its spawn ring and clear its object: checked from the config alone, before anything
is imported to build an env (`mapush train` refuses a bad ring in a second, not after PyTorch's imports), and again
by every pushing env (`PushingEnv.validate`)."""

from __future__ import annotations

import math

from mapush.errors import BadInput
from mapush.sim.shapes import object_radius


def ring_capacity(radius: float, min_distance: float) -> int:
    """Most robots that fit on a ring of `radius` with centres at least `min_distance` apart."""
    if min_distance >= 2 * radius:
        return 1
    return math.floor(math.pi / math.asin(min_distance / (2 * radius)) + 1e-9)


def check_agent_count(task_cfg: dict, min_distance: float) -> None:
    """Raise BadInput unless the task's agent count fits its spawn ring."""
    n, cap = task_cfg["num_agents"], ring_capacity(task_cfg["spawn"]["agent_radius"][0], min_distance)
    if not isinstance(n, int) or not 1 <= n <= cap:
        raise BadInput(f"task.num_agents={n} does not fit the {task_cfg['name']} spawn ring; valid: 1 to {cap}")


def check_spawn_ring(cfg: dict) -> None:
    """Raise BadInput unless a robot on the task's spawn ring clears the object: the ring's inner radius must
    exceed the object's reach from its centre plus half the robot's footprint length (`lowlevel.size`)."""
    inner, robot_reach = cfg["task"]["spawn"]["agent_radius"][0], max(cfg["lowlevel"]["size"][:2]) / 2
    least = object_radius(cfg["task"]["object"]) + robot_reach
    if not inner > least:
        raise BadInput(
            f"task.spawn.agent_radius={list(cfg['task']['spawn']['agent_radius'])} starts robots inside the "
            f"{cfg['task']['name']}; valid: an inner radius above {least:.3f} m (object reach + half a robot)"
        )


def check_spawn(cfg: dict) -> None:
    """`check_agent_count` and `check_spawn_ring` of a config whose level spawns robots on a ring around the object
    (one that sets `level.min_spawn_distance`); nothing for one that does not (the Go1's locomotion level)."""
    if "min_spawn_distance" not in cfg["level"]:
        return
    check_agent_count(cfg["task"], cfg["level"]["min_spawn_distance"])
    check_spawn_ring(cfg)
