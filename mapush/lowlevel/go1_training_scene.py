"""The locomotion env's scene (`level=locomotion`): one Go1 on flat ground with the servo settings of the go1
backend, and the free loads and the teammates its events ask for (`level.events.load`, `level.events.teammates`;
`mapush/envs/locomotion_events.py`)."""

from __future__ import annotations

import mujoco

from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1_model import go1_spec, standalone_spec

LOAD_BODIES = {"box": "load_box", "cylinder": "load_cylinder"}
"""The free bodies the load event adds, by shape; each episode with a load uses one, the other waits
at its `PARKED_XY`."""
ROBOT_NQ, ROBOT_NV = 7 + len(go1.JOINT_NAMES), 6 + len(go1.JOINT_NAMES)
"""The Go1's columns of qpos and qvel (its free joint, then its joints), which come first: any load follows."""
PARKED_XY = {"box": (100.0, 100.0), "cylinder": (100.0, -100.0)}
"""m; where each load waits when not in use, beyond any robot's reach in an episode and apart from the other."""
MATE_PREFIX = "mate{}/"
"""The name prefix of teammate k, a Go1 attached to the scene after the robot and any loads."""
MATE_PARKED_XY = (-100.0, 100.0)
"""m; where teammate k stands when not in use (k m further along x), beyond reach and apart from the loads."""
LOAD_GEOM_FRICTION = 0.1
"""A load's own sliding friction, below the floor's and the Go1's: MuJoCo takes the larger of a contact's two, so
the floor sets the load's drag (`resistance_n` picks its mass) and the robot's 1.0 its grip, as in a pushing scene."""


def locomotion_spec(robot: dict, timestep: float) -> mujoco.MjSpec:
    """One Go1 on flat ground with the go1 backend's servo gains (`robot`, a lowlevel config) and the sim's
    timestep; its 12 actuators come first. The locomotion env's events add what they need (`add_loads`,
    `add_teammates`) before it is compiled."""
    return standalone_spec(robot["kp"], robot["kd"], timestep, robot.get("torque_limits"))


def add_loads(spec: mujoco.MjSpec, box_size_m: list[float], cylinder_size_m: list[float]) -> None:
    """A free box (length, width, height) and a free cylinder (radius, height), each parked at its `PARKED_XY`
    with mass 1 kg (the env draws each env's own) and the low friction `LOAD_GEOM_FRICTION`."""
    box, cylinder = box_size_m, cylinder_size_m
    shapes = {
        "box": (mujoco.mjtGeom.mjGEOM_BOX, [box[0] / 2, box[1] / 2, box[2] / 2], box[2] / 2),
        "cylinder": (mujoco.mjtGeom.mjGEOM_CYLINDER, [cylinder[0], cylinder[1] / 2, 0.0], cylinder[1] / 2),
    }
    for shape, (kind, size, half_height) in shapes.items():
        body = spec.worldbody.add_body(name=LOAD_BODIES[shape], pos=[*PARKED_XY[shape], half_height])
        body.add_freejoint()
        body.add_geom(type=kind, size=size, mass=1.0, friction=[LOAD_GEOM_FRICTION, 0.005, 0.0001])


def add_teammates(spec: mujoco.MjSpec, robot: dict, count: int) -> None:
    """`count` more Go1s with the robot's servo, torque caps and foot friction, named `MATE_PREFIX`."""
    for k in range(count):
        mate = go1_spec(robot["kp"], robot["kd"], robot.get("torque_limits"), foot_friction=robot["foot_friction"])
        spec.attach(mate, frame=spec.worldbody.add_frame(), prefix=MATE_PREFIX.format(k))
