"""The Go1 as an MjSpec built from `go1_constants`: a floating trunk, 4 legs of 3 hinge joints, primitive shapes.

Every joint has a PD servo (MuJoCo `position` actuator: torque = kp (target - q) - kd qdot), evaluated at every
physics step (200 Hz with the 5 ms timestep) and capped at the motor's torque limit. The spec can be compiled on
its own (`standalone_spec`) or attached N times by prefix into a pushing scene (`MjSpec.attach`), as the tracker's
robot is. `go1_spec(...).to_xml()` writes it as MJCF.
"""

from __future__ import annotations

import mujoco

from mapush.lowlevel import go1_constants as go1

GEOM = mujoco.mjtGeom


def go1_spec(
    kp: float,
    kd: float,
    torque_limits: tuple[float, float, float] | None = None,
    armature: float = 0.01,
    foot_friction: float = 1.0,
    rgba: tuple[float, float, float, float] = (0.2, 0.4, 0.9, 1.0),
) -> mujoco.MjSpec:
    """One Go1 whose root body `trunk` carries a free joint `root`, with PD servos named after the joints.

    Args:
        kp: N m/rad, the servos' stiffness. kd: N m s/rad, their damping.
        torque_limits: N m, the (hip, thigh, calf) servos' torque caps; None: the motors' specification
            (`go1_constants.TORQUE_LIMIT`).
        armature: kg m^2, reflected rotor inertia of each joint (keeps the light calf stable under implicit
            integration).
        foot_friction: sliding friction of the feet (MuJoCo combines contacts by max).
    """
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    height = go1.standing_height()
    trunk = spec.worldbody.add_body(name=go1.ROOT_BODY, pos=[0.0, 0.0, height])
    trunk.add_freejoint(name=go1.ROOT_JOINT)
    mass, com, inertia = go1.TRUNK_INERTIAL
    trunk.mass, trunk.ipos, trunk.inertia, trunk.explicitinertial = mass, com, inertia, True
    half = [s / 2 for s in go1.TRUNK_SIZE]
    trunk.add_geom(name="trunk_box", type=GEOM.mjGEOM_BOX, size=half, rgba=list(rgba))
    for leg in go1.LEGS:
        _add_leg(trunk, leg, armature, foot_friction)
    caps = dict(zip(go1.JOINTS, torque_limits, strict=True)) if torque_limits else go1.TORQUE_LIMIT
    for name in go1.JOINT_NAMES:
        limit = caps[name.split("_")[1]]
        actuator = spec.add_actuator(name=name.replace("_joint", ""), target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=kp, kv=kd)
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-limit, limit]
    return spec


def _add_leg(trunk, leg: str, armature: float, foot_friction: float) -> None:
    sx, sy = go1.LEG_SIGNS[leg]
    dark = [0.15, 0.15, 0.15, 1.0]

    def inertial(body, values, mirror_y: bool = True) -> None:
        mass, (x, y, z), inertia = values
        body.mass, body.ipos, body.inertia = mass, [x, y * (sy if mirror_y else 1), z], list(inertia)
        body.explicitinertial = True

    def hinge(body, joint: str, axis: list[float]) -> None:
        low, high = go1.JOINT_RANGE[joint]
        if joint == "hip" and sy < 0:  # abduction ranges mirror on the right legs
            low, high = -high, -low
        body.add_joint(
            name=f"{leg}_{joint}_joint",
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=axis,
            range=[low, high],
            armature=armature,
            damping=0.0,
        )

    hip = trunk.add_body(name=f"{leg}_hip", pos=[sx * go1.HIP_OFFSET[0], sy * go1.HIP_OFFSET[1], 0.0])
    hinge(hip, "hip", [1.0, 0.0, 0.0])
    inertial(hip, go1.HIP_INERTIAL)
    hip.add_geom(type=GEOM.mjGEOM_CYLINDER, size=[0.046, 0.02], quat=[0.7071068, 0.7071068, 0, 0], rgba=dark)

    thigh = hip.add_body(name=f"{leg}_thigh", pos=[0.0, sy * go1.THIGH_OFFSET, 0.0])
    hinge(thigh, "thigh", [0.0, 1.0, 0.0])
    inertial(thigh, go1.THIGH_INERTIAL)
    thigh.add_geom(type=GEOM.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -go1.THIGH_LENGTH], size=[0.022, 0, 0])

    calf = thigh.add_body(name=f"{leg}_calf", pos=[0.0, 0.0, -go1.THIGH_LENGTH])
    hinge(calf, "calf", [0.0, 1.0, 0.0])
    mass, com, inertia = go1.CALF_INERTIAL
    foot_z = -go1.CALF_LENGTH
    # the foot's mass joins the calf's: one body, its centre of mass shifted toward the foot
    total = mass + go1.FOOT_MASS
    calf.mass = total
    calf.ipos = [com[0] * mass / total, com[1] * mass / total, (com[2] * mass + foot_z * go1.FOOT_MASS) / total]
    calf.inertia = list(inertia)
    calf.explicitinertial = True
    calf.add_geom(type=GEOM.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, foot_z * 0.9], size=[0.013, 0, 0], rgba=dark)
    calf.add_geom(
        name=f"{leg}_foot",
        type=GEOM.mjGEOM_SPHERE,
        size=[go1.FOOT_RADIUS, 0, 0],
        pos=[0.0, 0.0, foot_z],
        friction=[foot_friction, 0.005, 0.0001],
        rgba=dark,
    )


def standalone_spec(
    kp: float, kd: float, timestep: float = 0.005, torque_limits: tuple[float, float, float] | None = None
) -> mujoco.MjSpec:
    """A Go1 on a flat floor (names unprefixed), for tests and single-robot checks."""
    spec = go1_spec(kp, kd, torque_limits)
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.worldbody.add_geom(name="floor", type=GEOM.mjGEOM_PLANE, size=[20, 20, 0.1], friction=[1.0, 0.005, 0.0001])
    return spec
