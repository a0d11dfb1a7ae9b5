"""How the object moved in each recorded episode: read back from an episodes.mcap, summed up per episode.

`mapush logs episodes FILE` prints these rows. They answer what a success rate cannot: did a timeout wander
(travel far beyond the start-to-end distance), stall (the object still most of the time), jam against an
obstacle (the object's footprint touching a block) or stall with two robots jammed against each other, and how
far the object strayed from the reference path.

Everything is read from the file alone: the object's and the robots' poses from `/tf`, the object's footprint, the
reference path, the target and the obstacle blocks from each episode's first `/scene`, the outcome from
`/episode` (topics: `mapush.logging.episodes`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from mapush.errors import BadInput
from mapush.logging.foxglove_scene import OBJECT, robot_frame
from mapush.logging.mcap_files import stream_records
from mapush.planning import paths
from mapush.planning.geometry import corners, polygon_gap, transform
from mapush.sim.shapes import object_hull

STALL_SPEED = 0.05
"""m/s; the object counts as stalled below this speed."""
TOUCH_M = 0.02
"""m; the object's footprint counts as touching a block within this gap (as the `object_hit_obstacle` check)."""
JAM_M = 0.8
"""m; two robots whose centres are closer than this (a Go1 is 0.65 m long, 0.28 m wide) are body to body."""


@dataclass
class Track:
    """One recorded episode: poses at every step and the scene it was played in."""

    end: dict  # the `/episode` message: outcome, exception, time_s, return, label
    dt: float  # s between steps
    object_xy: np.ndarray  # (T, 2)
    object_yaw: np.ndarray  # (T,)
    robot_xy: np.ndarray  # (T, N, 2)
    hull: np.ndarray  # (H, 2) the object's footprint, convex, in its own frame
    path: np.ndarray | None  # (P, 2) the reference path (high level), else None
    goal_xy: np.ndarray  # (2,) the final target (high level) or the first subgoal (mid level)
    obstacles: np.ndarray  # (K, 5) blocks: x, y, yaw, length, width; K = 0 without obstacles


def _yaw(q) -> float:
    """Heading of a quaternion that turns about z only (as the scene writes every pose)."""
    return 2.0 * math.atan2(q.z, q.w)


def _scene_geometry(scene: SceneUpdate) -> dict:
    """The object's footprint, the goal, the reference path and the obstacles of one `/scene` message."""
    entities = {e.id: e for e in scene.entities}
    if "object" not in entities:
        raise ValueError("no object")
    obj = entities["object"]
    parts = [
        {"type": "box", "size": [c.size.x, c.size.y, c.size.z], "pos": [c.pose.position.x, c.pose.position.y]}
        for c in obj.cubes
    ] + [
        {"type": "cylinder", "size": [c.size.x / 2, c.size.z], "pos": [c.pose.position.x, c.pose.position.y]}
        for c in obj.cylinders
    ]
    goal = entities.get("target", entities["subgoal"]).cylinders[0].pose.position
    path = None
    if "path" in entities and entities["path"].lines:
        path = np.array([(p.x, p.y) for p in entities["path"].lines[0].points])
    blocks = entities["obstacles"].cubes if "obstacles" in entities else []
    obstacles = np.array(
        [(c.pose.position.x, c.pose.position.y, _yaw(c.pose.orientation), c.size.x, c.size.y) for c in blocks]
    ).reshape(-1, 5)
    return {
        "hull": object_hull({"parts": parts}),
        "goal_xy": np.array([goal.x, goal.y]),
        "path": path,
        "obstacles": obstacles,
    }


def read_tracks(file: Path) -> list[Track]:
    """Every finished episode of an episodes.mcap of a pushing level (finished or cut: a cut file keeps the
    episodes written before the cut)."""
    contents = stream_records(Path(file))
    topics = {cid: channel.topic for cid, channel in contents.channels.items()}
    tracks: list[Track] = []
    poses: list[tuple[float, float, float]] = []  # the object's x, y, yaw at each step
    robots: list[list[tuple[float, float]]] = []  # every robot's x, y at each step
    times: list[int] = []
    scene: dict | None = None
    for message in contents.messages:
        topic = topics.get(message.channel_id)
        if topic == "/tf":
            frames = {t.child_frame_id: t for t in FrameTransforms.FromString(message.data).transforms}
            obj = frames[OBJECT]
            poses.append((obj.translation.x, obj.translation.y, _yaw(obj.rotation)))
            bases = [frames[robot_frame(i)] for i in range(len(frames)) if robot_frame(i) in frames]
            robots.append([(t.translation.x, t.translation.y) for t in bases])
            times.append(message.log_time)
        elif topic == "/scene" and scene is None:
            try:
                scene = _scene_geometry(SceneUpdate.FromString(message.data))
            except ValueError:
                raise BadInput(
                    f"{str(file)!r} has no object in its scene; valid: the episodes.mcap of a pushing level "
                    "(level=mid, high, mid_long)"
                ) from None
        elif topic == "/episode" and poses:
            pose = np.array(poses)  # (T, 3)
            dt = float(np.median(np.diff(times))) / 1e9 if len(times) > 1 else 0.0
            tracks.append(
                Track(
                    end=json.loads(message.data),
                    dt=dt,
                    object_xy=pose[:, :2],
                    object_yaw=pose[:, 2],
                    robot_xy=np.array(robots, dtype=float).reshape(len(robots), -1, 2),
                    **scene,
                )
            )
            poses, robots, times, scene = [], [], [], None
    return tracks


def episode_stats(track: Track) -> dict:
    """One episode summed up (distances in m, speeds in m/s, fractions of the episode's steps).

    - `travel_m`: length of the object centre's trajectory; `net_m`: straight from its start to its end;
    - `path_m`: length of the reference path (NaN without one); `off_path_m`, `off_path_max_m`: the object
      centre's mean and largest distance from the reference path's points (evenly spaced, so an overestimate
      by at most half their spacing);
    - `speed`: the object's mean speed; `stalled`: the fraction of steps it moved slower than `STALL_SPEED`;
    - `touching`: the fraction of steps its footprint was within `TOUCH_M` of an obstacle block;
    - `jammed`: the fraction of steps the object stalled while two robots stood within `JAM_M` of each other;
    - `goal_m`: the object centre's distance from the goal at the end.
    """
    xy = torch.as_tensor(track.object_xy, dtype=torch.float64)
    step = torch.linalg.vector_norm(xy[1:] - xy[:-1], dim=-1)
    speed = step / track.dt  # empty when the episode has one step (dt 0)
    row = {
        "outcome": track.end["outcome"] + (f" ({track.end['exception']})" if track.end.get("exception") else ""),
        "time_s": float(track.end["time_s"]),
        "travel_m": float(step.sum()),
        "net_m": float(torch.linalg.vector_norm(xy[-1] - xy[0])),
        "speed": float(speed.mean()) if len(speed) else 0.0,
        "stalled": float((speed < STALL_SPEED).double().mean()) if len(speed) else 0.0,
        "goal_m": float(torch.linalg.vector_norm(xy[-1] - torch.as_tensor(track.goal_xy, dtype=torch.float64))),
        "path_m": math.nan,
        "off_path_m": math.nan,
        "off_path_max_m": math.nan,
        "touching": 0.0,
        "jammed": 0.0,
    }
    robots = torch.as_tensor(track.robot_xy, dtype=torch.float64)  # (T, N, 2)
    if robots.shape[1] > 1 and len(speed):
        same = torch.eye(robots.shape[1], dtype=torch.bool)
        apart = torch.cdist(robots[1:], robots[1:]).masked_fill(same, math.inf)  # where each step left them
        close = apart.flatten(1).amin(-1) < JAM_M
        row["jammed"] = float(((speed < STALL_SPEED) & close).double().mean())
    if track.path is not None and len(track.path) > 1:
        path = torch.as_tensor(track.path, dtype=torch.float64)
        off = paths.distance_to_path(path.expand(len(xy), *path.shape), xy)
        row.update(path_m=float(paths.length(path)), off_path_m=float(off.mean()), off_path_max_m=float(off.max()))
    if len(track.obstacles):
        hull = transform(
            torch.as_tensor(track.hull, dtype=torch.float64), xy, torch.as_tensor(track.object_yaw, dtype=torch.float64)
        )  # (T, H, 2)
        blocks = corners(torch.as_tensor(track.obstacles, dtype=torch.float64))  # (K, 4, 2)
        gap = polygon_gap(hull.unsqueeze(1), blocks.unsqueeze(0))  # (T, K)
        row["touching"] = float((gap.amin(-1) < TOUCH_M).double().mean())
    return row


COLUMNS = {  # column: (heading, format)
    "outcome": ("outcome", "{}"),
    "time_s": ("time s", "{:.1f}"),
    "travel_m": ("travel m", "{:.1f}"),
    "net_m": ("net m", "{:.1f}"),
    "path_m": ("path m", "{:.1f}"),
    "off_path_m": ("off path m", "{:.2f}"),
    "off_path_max_m": ("max off m", "{:.2f}"),
    "speed": ("speed m/s", "{:.2f}"),
    "stalled": ("stalled", "{:.0%}"),
    "touching": ("touching", "{:.0%}"),
    "jammed": ("jammed", "{:.0%}"),
    "goal_m": ("to goal m", "{:.1f}"),
}


def format_rows(rows: list[dict]) -> str:
    """A Markdown table of `episode_stats` rows, one line per episode, with the mean of each number below."""
    head = ["#", *(heading for heading, _ in COLUMNS.values())]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def cells(row: dict) -> list[str]:
        return [
            ("—" if isinstance(row[k], float) and math.isnan(row[k]) else fmt.format(row[k]))
            for k, (_, fmt) in COLUMNS.items()
        ]

    for i, row in enumerate(rows):
        lines.append("| " + " | ".join([str(i), *cells(row)]) + " |")
    if len(rows) > 1:
        mean = {k: float(np.mean([r[k] for r in rows])) for k in COLUMNS if k != "outcome"}
        successes = sum(r["outcome"] == "success" for r in rows)
        mean["outcome"] = f"{successes}/{len(rows)} success"
        lines.append("| " + " | ".join(["mean", *cells(mean)]) + " |")
    return "\n".join(lines)
