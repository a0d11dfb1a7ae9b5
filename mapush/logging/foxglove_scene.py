"""Foxglove messages of one env at one instant: the 3D scene (`foxglove.SceneUpdate`) and its frame transforms.

Frames: `world` is the arena frame (origin at the centre, z up); `object` and `robot<i>` are the object's body
frame and each robot's base frame (x forward), given by `foxglove.FrameTransforms` every step. The object's
parts and the robots are drawn in their own frames, so that the 3D panel moves them with the transforms; the
walls, obstacles, goal markers and the reference path are drawn in `world`.

The whole scene is sent every step, so any instant of a recording shows everything, whatever was seeked over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    Duration,
    FrameTransform,
    FrameTransforms,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    Timestamp,
    Vector3,
)

from mapush.planning.geometry import PARKED

WORLD = "world"
OBJECT = "object"

RGBA = {  # one palette for the episode files and the videos (mapush.viz)
    "wall": (0.55, 0.55, 0.6, 1.0),
    "object": (0.95, 0.55, 0.15, 1.0),
    "robots": ((0.2, 0.45, 0.95, 1.0), (0.85, 0.25, 0.3, 1.0), (0.3, 0.7, 0.35, 1.0), (0.6, 0.35, 0.85, 1.0)),
    "heading": (1.0, 1.0, 1.0, 1.0),
    "subgoal": (0.1, 0.8, 0.4, 0.35),
    "target": (0.95, 0.85, 0.1, 0.45),
    "obstacle": (0.35, 0.35, 0.4, 1.0),
    "path": (0.1, 0.6, 0.95, 1.0),
}


def _color(rgba: tuple[float, float, float, float]) -> Color:
    return Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])


WALL = _color(RGBA["wall"])
OBJECT_COLOR = _color(RGBA["object"])
ROBOT_COLORS = tuple(_color(rgba) for rgba in RGBA["robots"])
HEADING = _color(RGBA["heading"])
SUBGOAL = _color(RGBA["subgoal"])
TARGET = _color(RGBA["target"])
OBSTACLE = _color(RGBA["obstacle"])
PATH = _color(RGBA["path"])
MARKER_HEIGHT = 0.02  # m; goal discs lie flat on the floor
GOAL_RADIUS = 0.15  # m; the discs of the robots' own navigation goals (H+L)


def robot_frame(i: int) -> str:
    """Frame id of robot i's base."""
    return f"robot{i}"


@dataclass(frozen=True)
class SceneLayout:
    """What a recording needs from the config to draw the scene; nothing here changes during a run."""

    arena_size: float
    wall_height: float
    wall_thickness: float
    object_parts: tuple[dict, ...]
    robot_size: tuple[float, float, float]
    num_agents: int
    success_distance: float
    obstacle_height: float  # m; 0 for levels without obstacles

    @classmethod
    def from_config(cls, cfg: dict) -> SceneLayout:
        sim = cfg["sim"]
        return cls(
            arena_size=float(sim["arena_size"]),
            wall_height=float(sim["wall_height"]),
            wall_thickness=float(sim["wall_thickness"]),
            object_parts=tuple(cfg["task"]["object"]["parts"]),
            robot_size=tuple(float(x) for x in cfg["lowlevel"]["size"]),
            num_agents=int(cfg["task"]["num_agents"]),
            success_distance=float(cfg["level"]["success_distance"]),
            obstacle_height=float(cfg["level"]["obstacles"]["size"][2]) if "obstacles" in cfg["level"] else 0.0,
        )

    def scene(self, frame: dict[str, np.ndarray], t_ns: int) -> SceneUpdate:
        return scene_update(self, frame, t_ns)

    def transforms(self, frame: dict[str, np.ndarray], t_ns: int) -> FrameTransforms:
        return frame_transforms(self, frame, t_ns)


def timestamp(t_ns: int) -> Timestamp:
    return Timestamp(sec=t_ns // 1_000_000_000, nsec=t_ns % 1_000_000_000)


def _yaw_quaternion(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw: float = 0.0) -> Pose:
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=_yaw_quaternion(yaw))


def scene_entity(ts: Timestamp, frame: str, entity_id: str, **primitives) -> SceneEntity:
    # lifetime 0 = until replaced by the next update of the same id
    return SceneEntity(timestamp=ts, frame_id=frame, id=entity_id, lifetime=Duration(sec=0, nsec=0), **primitives)


def _disc(x: float, y: float, radius: float, color: Color) -> CylinderPrimitive:
    return CylinderPrimitive(
        pose=_pose(x, y, MARKER_HEIGHT / 2),
        size=Vector3(x=2 * radius, y=2 * radius, z=MARKER_HEIGHT),
        bottom_scale=1.0,
        top_scale=1.0,
        color=color,
    )


def _walls(layout: SceneLayout) -> list[CubePrimitive]:
    half, t, h = layout.arena_size / 2, layout.wall_thickness, layout.wall_height
    offset, span = half + t / 2, layout.arena_size + 2 * t
    return [
        CubePrimitive(pose=_pose(x, y, h / 2), size=Vector3(x=sx, y=sy, z=h), color=WALL)
        for x, y, sx, sy in ((offset, 0, t, span), (-offset, 0, t, span), (0, offset, span, t), (0, -offset, span, t))
    ]


def _object_parts(layout: SceneLayout) -> tuple[list[CubePrimitive], list[CylinderPrimitive]]:
    cubes, cylinders = [], []
    for part in layout.object_parts:
        px, py = part["pos"]
        if part["type"] == "box":
            sx, sy, sz = part["size"]
            cubes.append(CubePrimitive(pose=_pose(px, py), size=Vector3(x=sx, y=sy, z=sz), color=OBJECT_COLOR))
        else:
            radius, h = part["size"]
            cylinders.append(
                CylinderPrimitive(
                    pose=_pose(px, py),
                    size=Vector3(x=2 * radius, y=2 * radius, z=h),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=OBJECT_COLOR,
                )
            )
    return cubes, cylinders


def scene_update(layout: SceneLayout, frame: dict[str, np.ndarray], t_ns: int) -> SceneUpdate:
    """The full scene of one env at one instant.

    Args:
        layout: the run's fixed geometry.
        frame: one env's `scene_frame()` row: `subgoal_xy` (2,), and when the level has them `target_xy` (2,),
            `obstacles` (K, 4, 2) footprint corners (NaN rows are absent obstacles), `path` (P, 2) and
            `robot_goal_xy` (A, 2), the robots' own navigation goals (H+L).
        t_ns: the message time.
    """
    ts = timestamp(t_ns)
    length, width, height = layout.robot_size
    cubes, cylinders = _object_parts(layout)
    entities = [
        scene_entity(ts, WORLD, "arena", cubes=_walls(layout)),
        scene_entity(ts, OBJECT, "object", cubes=cubes, cylinders=cylinders),
        scene_entity(ts, WORLD, "subgoal", cylinders=[_disc(*frame["subgoal_xy"], layout.success_distance, SUBGOAL)]),
    ]
    for i in range(layout.num_agents):
        color = ROBOT_COLORS[i % len(ROBOT_COLORS)]
        body = CubePrimitive(pose=_pose(), size=Vector3(x=length, y=width, z=height), color=color)
        heading = ArrowPrimitive(
            pose=_pose(z=height / 2 + 0.02),
            shaft_length=0.6 * length,
            shaft_diameter=0.04,
            head_length=0.15,
            head_diameter=0.12,
            color=HEADING,
        )
        entities.append(scene_entity(ts, robot_frame(i), robot_frame(i), cubes=[body], arrows=[heading]))
    if "target_xy" in frame:
        entities.append(
            scene_entity(ts, WORLD, "target", cylinders=[_disc(*frame["target_xy"], layout.success_distance, TARGET)])
        )
    if "obstacles" in frame:
        cubes = _obstacle_cubes(frame["obstacles"], layout.obstacle_height)
        entities.append(scene_entity(ts, WORLD, "obstacles", cubes=cubes))
    if "robot_goal_xy" in frame:  # H+L: each robot's navigation goal, in its colour
        discs = [
            _disc(*xy, GOAL_RADIUS, ROBOT_COLORS[i % len(ROBOT_COLORS)]) for i, xy in enumerate(frame["robot_goal_xy"])
        ]
        entities.append(scene_entity(ts, WORLD, "robot_goals", cylinders=discs))
    if "path" in frame and len(frame["path"]) > 1:
        points = [Point3(x=float(x), y=float(y), z=MARKER_HEIGHT) for x, y in frame["path"]]
        line = LinePrimitive(
            type=LinePrimitiveLineType.LineStrip, pose=_pose(), thickness=0.05, points=points, color=PATH
        )
        entities.append(scene_entity(ts, WORLD, "path", lines=[line]))
    return SceneUpdate(entities=entities)


def _obstacle_cubes(corners: np.ndarray, height: float) -> list[CubePrimitive]:
    """Rotated rectangular blocks of `height` from their (K, 4, 2) footprint corners; parked ones are skipped."""
    cubes = []
    for quad in corners:
        centre = quad.mean(0)
        if not np.isfinite(quad).all() or centre[0] >= PARKED / 2:
            continue
        edge_a, edge_b = quad[1] - quad[0], quad[2] - quad[1]
        yaw = math.atan2(edge_a[1], edge_a[0])
        size = Vector3(x=float(np.linalg.norm(edge_a)), y=float(np.linalg.norm(edge_b)), z=height)
        cubes.append(CubePrimitive(pose=_pose(*map(float, centre), height / 2, yaw), size=size, color=OBSTACLE))
    return cubes


def frame_transforms(layout: SceneLayout, frame: dict[str, np.ndarray], t_ns: int) -> FrameTransforms:
    """world -> object and world -> robot<i> at one instant."""
    ts = timestamp(t_ns)
    ox, oy = map(float, frame["object_xy"])
    transforms = [
        FrameTransform(
            timestamp=ts,
            parent_frame_id=WORLD,
            child_frame_id=OBJECT,
            translation=Vector3(x=ox, y=oy, z=float(frame["object_z"])),
            rotation=_yaw_quaternion(float(frame["object_yaw"])),
        )
    ]
    z = layout.robot_size[2] / 2
    for i in range(layout.num_agents):
        rx, ry = map(float, frame["robot_xy"][i])
        transforms.append(
            FrameTransform(
                timestamp=ts,
                parent_frame_id=WORLD,
                child_frame_id=robot_frame(i),
                translation=Vector3(x=rx, y=ry, z=z),
                rotation=_yaw_quaternion(float(frame["robot_yaw"][i])),
            )
        )
    return FrameTransforms(transforms=transforms)
