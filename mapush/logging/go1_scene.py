"""Foxglove messages of the low level (`level=locomotion`): one Go1 on flat ground, drawn from its MuJoCo geoms.

Every geom of the model (trunk box, hip cylinders, thigh and calf capsules, foot spheres) is drawn in `world` at
its simulated pose each step, so the 3D panel shows the gait itself. Two arrows above the trunk compare the
commanded planar velocity (green) with the actual one (white); `/tf` gives world -> robot0 (the trunk).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    Pose,
    Quaternion,
    SceneUpdate,
    SpherePrimitive,
    Vector3,
)

from mapush.logging.foxglove_scene import WORLD, robot_frame, scene_entity, timestamp
from mapush.sim.geoms import drawn_geom_ids

COMMAND = Color(r=0.2, g=0.85, b=0.35, a=1.0)
VELOCITY = Color(r=1.0, g=1.0, b=1.0, a=1.0)
ARROW_HEIGHT = 0.25  # m above the trunk
ARROW_PER_MPS = 1.0  # m of shaft per m/s


def _pose(xyz: np.ndarray, quat: np.ndarray) -> Pose:
    return Pose(
        position=Vector3(x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
        orientation=Quaternion(w=float(quat[0]), x=float(quat[1]), y=float(quat[2]), z=float(quat[3])),
    )


def _arrow(origin: np.ndarray, planar: np.ndarray, color: Color) -> ArrowPrimitive:
    speed = float(np.linalg.norm(planar))
    yaw = float(np.arctan2(planar[1], planar[0]))
    quat = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    return ArrowPrimitive(
        pose=_pose(origin, quat),
        shaft_length=max(ARROW_PER_MPS * speed, 1e-3),
        shaft_diameter=0.02,
        head_length=0.06,
        head_diameter=0.05,
        color=color,
    )


@dataclass(frozen=True)
class Go1Layout:
    """The Go1's drawable geoms (MuJoCo type, size, colour), fixed for a run; the floor is left out."""

    geoms: tuple[tuple[int, tuple[float, float, float], tuple[float, float, float, float]], ...]
    geom_ids: tuple[int, ...]
    num_agents: int = 1

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> Go1Layout:
        ids = drawn_geom_ids(model)
        geoms = tuple(
            (int(model.geom_type[g]), tuple(map(float, model.geom_size[g])), tuple(map(float, model.geom_rgba[g])))
            for g in ids
        )
        return cls(geoms=geoms, geom_ids=ids)

    def scene(self, frame: dict[str, np.ndarray], t_ns: int) -> SceneUpdate:
        """The Go1 at one instant. frame: `geom_xpos` (G, 3) and `geom_xquat` (G, 4) of the drawn geoms,
        `trunk_xyz` (3,), `command_xy` and `velocity_xy` (2,), both in the world frame, m/s."""
        ts = timestamp(t_ns)
        cubes, cylinders, spheres = [], [], []
        for (kind, size, rgba), xyz, quat in zip(self.geoms, frame["geom_xpos"], frame["geom_xquat"], strict=True):
            pose, color = _pose(xyz, quat), Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
            if kind == mujoco.mjtGeom.mjGEOM_BOX:
                cubes.append(
                    CubePrimitive(pose=pose, size=Vector3(x=2 * size[0], y=2 * size[1], z=2 * size[2]), color=color)
                )
            elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
                d = 2 * size[0]
                spheres.append(SpherePrimitive(pose=pose, size=Vector3(x=d, y=d, z=d), color=color))
            else:  # cylinders and capsules (a capsule's length includes its end caps)
                d = 2 * size[0]
                length = 2 * size[1] + (d if kind == mujoco.mjtGeom.mjGEOM_CAPSULE else 0.0)
                cylinders.append(
                    CylinderPrimitive(
                        pose=pose, size=Vector3(x=d, y=d, z=length), bottom_scale=1.0, top_scale=1.0, color=color
                    )
                )
        above = frame["trunk_xyz"] + np.array([0.0, 0.0, ARROW_HEIGHT])
        arrows = [_arrow(above, frame["command_xy"], COMMAND), _arrow(above, frame["velocity_xy"], VELOCITY)]
        robot = scene_entity(ts, WORLD, robot_frame(0), cubes=cubes, cylinders=cylinders, spheres=spheres)
        return SceneUpdate(entities=[robot, scene_entity(ts, WORLD, "velocity", arrows=arrows)])

    def transforms(self, frame: dict[str, np.ndarray], t_ns: int) -> FrameTransforms:
        """world -> robot0, the trunk's pose."""
        xyz, quat = frame["trunk_xyz"], frame["trunk_quat"]
        transform = FrameTransform(
            timestamp=timestamp(t_ns),
            parent_frame_id=WORLD,
            child_frame_id=robot_frame(0),
            translation=Vector3(x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
            rotation=Quaternion(w=float(quat[0]), x=float(quat[1]), y=float(quat[2]), z=float(quat[3])),
        )
        return FrameTransforms(transforms=[transform])
