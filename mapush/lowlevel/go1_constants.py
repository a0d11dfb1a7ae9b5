"""The Unitree Go1's published dimensions, masses, inertias, joint ranges and motor limits, and mapush's names.

Sources (facts, not code): Unitree's Go1 URDF (`go1_description`) as reproduced in public Go1 tooling (link
offsets, masses, centres of mass, principal inertias, joint ranges); Unitree's Go1 motor specification (23.7 N m
hip and thigh, 35.55 N m knee after the 1.5x knee reduction). Links are primitive shapes; the inertias are the
URDF's diagonals (its off-diagonal terms are under 2 % of them). Total mass 12.03 kg, the trunk 5.204 kg (the
original's copy of the URDF: 11.31 kg, its trunk 4.8 kg; docs/fidelity.md).
"""

from __future__ import annotations

import math

LEGS = ("FR", "FL", "RR", "RL")
"""Leg order of every 12-vector (joints, targets, torques): front right, front left, rear right, rear left."""
JOINTS = ("hip", "thigh", "calf")
"""Joints of a leg, in order: hip abduction (about x), hip flexion (about y), knee (about y)."""
JOINT_NAMES = tuple(f"{leg}_{joint}_joint" for leg in LEGS for joint in JOINTS)
FOOT_NAMES = tuple(f"{leg}_foot" for leg in LEGS)
ROOT_BODY = "trunk"
ROOT_JOINT = "root"

# (x sign, y sign) of each leg's hip in the trunk frame
LEG_SIGNS = {"FR": (1, -1), "FL": (1, 1), "RR": (-1, -1), "RL": (-1, 1)}

HIP_OFFSET = (0.1881, 0.04675)  # m; trunk origin -> hip abduction axis (x, |y|)
THIGH_OFFSET = 0.08  # m; hip abduction axis -> thigh joint, outward along y
THIGH_LENGTH = 0.213  # m; thigh joint -> knee
CALF_LENGTH = 0.213  # m; knee -> foot centre
FOOT_RADIUS = 0.02  # m
TRUNK_SIZE = (0.3762, 0.0935, 0.114)  # m; collision box (length, width, height)

# mass (kg), centre of mass (m, in the link frame; y for a left leg, mirrored for a right one), principal inertia
TRUNK_INERTIAL = (5.204, (0.0223, 0.002, -0.0005), (0.0168128557, 0.063009565, 0.0716547275))
HIP_INERTIAL = (0.591, (-0.005657, -0.008752, -0.000102), (0.000334008405, 0.000619101213, 0.00040057614))
THIGH_INERTIAL = (0.92, (-0.003342, -0.018054, -0.033451), (0.004431760472, 0.004485671726, 0.000740309489))
CALF_INERTIAL = (0.135862, (0.006197, 0.001408, -0.116695), (0.001088793059, 0.001100428748, 0.000024787446))
FOOT_MASS = 0.06  # kg

JOINT_RANGE = {"hip": (-0.863, 0.863), "thigh": (-0.686, 4.501), "calf": (-2.818, -0.888)}  # rad
TORQUE_LIMIT = {"hip": 23.7, "thigh": 23.7, "calf": 35.55}  # N m

DEFAULT_POSE = {"hip": 0.1, "thigh": 0.8, "calf": -1.5}
"""Standing joint angles, rad (hip abduction outward: +0.1 on the left legs, -0.1 on the right)."""


def default_joint_angles() -> tuple[float, ...]:
    """The 12 standing joint angles in `JOINT_NAMES` order."""
    angles = []
    for leg in LEGS:
        side = LEG_SIGNS[leg][1]
        angles += [side * DEFAULT_POSE["hip"], DEFAULT_POSE["thigh"], DEFAULT_POSE["calf"]]
    return tuple(angles)


def standing_height() -> float:
    """Trunk height (m) with every foot on the ground in the default pose (planar leg, abduction ignored)."""
    thigh, calf = DEFAULT_POSE["thigh"], DEFAULT_POSE["calf"]
    drop = THIGH_LENGTH * math.cos(thigh) + CALF_LENGTH * math.cos(thigh + calf)
    return drop * math.cos(DEFAULT_POSE["hip"]) + FOOT_RADIUS
