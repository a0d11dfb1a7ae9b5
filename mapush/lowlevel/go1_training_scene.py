"""The locomotion env's scene (`level=low`): one Go1 on flat ground with the servo settings of the go1 backend, and
the free loads and the teammates a run asks for (`level.randomize.load`, `level.randomize.teammates`)."""

from __future__ import annotations

import mujoco

from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1_model import go1_spec, standalone_spec

LOAD_BODIES = {"box": "load_box", "cylinder": "load_cylinder"}
"""The free bodies a run with `randomize.load` adds, by shape; each episode with a load uses one, the other waits
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


def locomotion_model(cfg: dict) -> mujoco.MjModel:
    """One Go1 on flat ground with the go1 backend's servo gains and the sim's timestep, and the loads and the
    teammates where a run asks for them (`load_fractions`, `teammate_fractions`). The Go1's 12 actuators come
    first."""
    robot = cfg["lowlevel"]
    spec = standalone_spec(robot["kp"], robot["kd"], cfg["sim"]["timestep"], robot.get("torque_limits"))
    load = cfg["level"]["randomize"].get("load")  # runs made before the key have none
    if any(load_fractions(cfg)):
        box, cylinder = load["box_size_m"], load["cylinder_size_m"]
        shapes = {
            "box": (mujoco.mjtGeom.mjGEOM_BOX, [box[0] / 2, box[1] / 2, box[2] / 2], box[2] / 2),
            "cylinder": (mujoco.mjtGeom.mjGEOM_CYLINDER, [cylinder[0], cylinder[1] / 2, 0.0], cylinder[1] / 2),
        }
        for shape, (kind, size, half_height) in shapes.items():
            body = spec.worldbody.add_body(name=LOAD_BODIES[shape], pos=[*PARKED_XY[shape], half_height])
            body.add_freejoint()
            body.add_geom(type=kind, size=size, mass=1.0, friction=[LOAD_GEOM_FRICTION, 0.005, 0.0001])
    for k in range(teammate_count(cfg)):
        mate = go1_spec(robot["kp"], robot["kd"], robot.get("torque_limits"), foot_friction=robot["foot_friction"])
        spec.attach(mate, frame=spec.worldbody.add_frame(), prefix=MATE_PREFIX.format(k))
    return spec.compile()


def load_fractions(cfg: dict) -> tuple[float, float]:
    """The share of training and of evaluation episodes that start with a load ahead (0, 0 without the key)."""
    load = cfg["level"]["randomize"].get("load") or {}
    return float(load.get("fraction", 0.0)), float(cfg["level"].get("eval_load_fraction", 0.0))


def teammate_fractions(cfg: dict) -> tuple[float, float]:
    """The share of training and of evaluation episodes with teammates beside the robot (0, 0 without the key)."""
    mates = cfg["level"]["randomize"].get("teammates") or {}
    return float(mates.get("fraction", 0.0)), float(cfg["level"].get("eval_teammate_fraction", 0.0))


def teammate_count(cfg: dict) -> int:
    """How many teammate Go1s the scene holds: `randomize.teammates.count` where any episode uses them, else 0."""
    return int(cfg["level"]["randomize"]["teammates"]["count"]) if any(teammate_fractions(cfg)) else 0
