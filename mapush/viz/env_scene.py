"""One env of a batch as a MuJoCo scene: its state in a single `MjData`, and what the model does not hold drawn as
user geoms, for MuJoCo's offscreen renderer (`mapush.viz.video`) and its native viewer (`mapush play`).

The model's own geoms show the arena, the object, the robots (tinted in the episode files' colours), the subgoal
marker and the obstacle blocks (mocap bodies, so they move with the copied state). The env's `scene_frame()` row
(what the MCAP episode files draw, `mapush.logging.foxglove_scene`) adds the success disc round the subgoal and,
where the level has them, the target, the reference path, the robots' own goals (H+L) and, at the low level, the
Go1's commanded (green) and actual (white) planar velocity.
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

from mapush.logging.foxglove_scene import GOAL_RADIUS, MARKER_HEIGHT, RGBA
from mapush.sim.scene import OBJECT_BODY, ROBOT_PREFIX

PATH_WIDTH = 0.04  # m; radius of the capsules that draw the reference path
ARROW_WIDTH = 0.03  # m; shaft radius of the velocity arrows
IDENTITY = np.eye(3).flatten()
HEADLIGHT = (0.35, 0.6)  # ambient, diffuse; MuJoCo's 0.1, 0.4 leave a scene with no lights of its own dark
CLIP_M = (0.05, 200.0)  # m; near and far clipping planes. MuJoCo scales its own by the model's extent, which the
# obstacle blocks parked 1 km off the arena (`PARKED`) stretch to ~1.4 km: a near plane 14 m out, past the camera's
# 9 m, cut the object and the robots out of every high-level frame


def rgba(name: str, index: int = 0) -> np.ndarray:
    """The episode files' colour `name` (`mapush.logging.foxglove_scene.RGBA`; `robots` by index) as MuJoCo's rgba."""
    color = RGBA[name]
    if name == "robots":
        color = color[index % len(color)]
    return np.array(color, dtype=np.float32)


COMMAND = np.array([*RGBA["subgoal"][:3], 1.0], dtype=np.float32)  # the commanded velocity, opaque green


FRAMING = 1.3
"""Camera distance per metre between the object and the target when both are framed (fits both at 45 degrees)."""


def env_row(env, env_id: int) -> dict[str, np.ndarray]:
    """Env `env_id`'s row of `env.scene_frame()` (the episode files' per-step picture) as numpy arrays."""
    return {name: value[env_id].numpy() for name, value in env.scene_frame().items()}


class EnvView:
    """A private copy of an env's model and one `MjData` that takes any env's state, plus the overlays.

    Args:
        env: a mapush env (any level).
        cfg: its config; `log.video.camera` places the camera, and the level's `success_distance` sizes the disc.
        width, height: the largest offscreen image the copy must allow, px.
    """

    def __init__(self, env, cfg: dict, width: int = 640, height: int = 480):
        self.model = env.sim.batch.get_model(0)  # a copy: the changes below stay out of the simulation
        self.model.vis.global_.offwidth = max(int(self.model.vis.global_.offwidth), width)
        self.model.vis.global_.offheight = max(int(self.model.vis.global_.offheight), height)
        self.model.vis.headlight.ambient[:], self.model.vis.headlight.diffuse[:] = HEADLIGHT
        self.model.vis.map.znear, self.model.vis.map.zfar = (m / self.model.stat.extent for m in CLIP_M)
        self._tint_robots(int(cfg["task"]["num_agents"]))
        self.data = mujoco.MjData(self.model)
        self.success_distance = float(cfg["level"].get("success_distance", 0.0))
        self.camera_cfg = cfg["log"]["video"]["camera"]

    def _tint_robots(self, num_agents: int) -> None:
        """Give robot i's geoms the episode files' colour of robot i (all robots share one spec's colour)."""
        for i in range(num_agents):
            prefix = ROBOT_PREFIX.format(i)
            bodies = [b for b in range(self.model.nbody) if self.model.body(b).name.startswith(prefix)]
            geoms = np.isin(self.model.geom_bodyid, bodies)
            self.model.geom_rgba[geoms] = rgba("robots", i)

    def load(self, env, env_id: int = 0) -> dict[str, np.ndarray]:
        """Copy env `env_id`'s state into `data` (positions follow by `mj_forward`); returns its scene row."""
        env.sim.batch.get_data(env_id, self.data)
        mujoco.mj_forward(self.model, self.data)
        return env_row(env, env_id)

    def set_camera(self, camera: mujoco.MjvCamera) -> None:
        """Point `camera` as `log.video.camera` says: tracking the object (the Go1's trunk), or at the arena centre."""
        cam = self.camera_cfg
        tracked = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
        if cam["track"]:
            camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            camera.trackbodyid = tracked if tracked >= 0 else 1  # the low level's first body is the trunk
        else:
            camera.type = mujoco.mjtCamera.mjCAMERA_FREE
            camera.lookat[:] = 0.0
        camera.distance = float(cam["distance"])
        camera.azimuth = float(cam["azimuth"])
        camera.elevation = float(cam["elevation"])

    def frame(self, camera: mujoco.MjvCamera, row: dict[str, np.ndarray]) -> None:
        """With a tracking camera and a final target (the high levels), look at the middle of the object and the
        target from far enough to show both and the path between (`set_camera` otherwise)."""
        cam = self.camera_cfg
        if not cam["track"] or "target_xy" not in row or "object_xy" not in row:
            return
        obj, target = row["object_xy"], row["target_xy"]
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.lookat[:2] = (obj + target) / 2
        camera.lookat[2] = 0.0
        span = float(np.linalg.norm(target - obj)) + 2 * self.success_distance
        camera.distance = max(float(cam["distance"]), FRAMING * span)

    def draw(self, scene: mujoco.MjvScene, row: dict[str, np.ndarray]) -> None:
        """Add the overlays of a scene row to `scene` as user geoms, after its model geoms."""
        if "subgoal_xy" in row and self.success_distance > 0:
            _disc(scene, row["subgoal_xy"], self.success_distance, rgba("subgoal"))
        if "target_xy" in row:
            _disc(scene, row["target_xy"], self.success_distance, rgba("target"))
        for i, xy in enumerate(row.get("robot_goal_xy", ())):
            _disc(scene, xy, GOAL_RADIUS, rgba("robots", i))
        path = row.get("path")
        if path is not None:
            path = path[np.isfinite(path).all(-1)]
            for a, b in itertools.pairwise(path):
                _connector(scene, mujoco.mjtGeom.mjGEOM_CAPSULE, PATH_WIDTH, a, b, MARKER_HEIGHT, rgba("path"))
        if "trunk_xyz" in row:
            base = row["trunk_xyz"][:2]
            z = float(row["trunk_xyz"][2]) + 0.2
            for velocity, color in ((row["command_xy"], COMMAND), (row["velocity_xy"], rgba("heading"))):
                if np.linalg.norm(velocity) > 1e-3:
                    _connector(scene, mujoco.mjtGeom.mjGEOM_ARROW, ARROW_WIDTH, base, base + velocity, z, color)


def _next_geom(scene: mujoco.MjvScene):
    """The scene's next free geom, or None when it is full (the overlay is then left out)."""
    if scene.ngeom >= scene.maxgeom:
        return None
    scene.ngeom += 1
    return scene.geoms[scene.ngeom - 1]


def _disc(scene: mujoco.MjvScene, xy: np.ndarray, radius: float, color: np.ndarray) -> None:
    """A flat disc of `radius` on the floor at `xy`."""
    geom = _next_geom(scene) if np.isfinite(xy).all() else None
    if geom is None:
        return
    pos = np.array([xy[0], xy[1], MARKER_HEIGHT / 2])
    size = np.array([radius, MARKER_HEIGHT / 2, 0.0])
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CYLINDER, size, pos, IDENTITY, color)


def _connector(scene, kind, width: float, a: np.ndarray, b: np.ndarray, z: float, color: np.ndarray) -> None:
    """A capsule or arrow from `a` to `b` (xy) at height `z`."""
    geom = _next_geom(scene)
    if geom is None:
        return
    mujoco.mjv_initGeom(geom, kind, np.zeros(3), np.zeros(3), IDENTITY, color)
    start = np.array([a[0], a[1], z], dtype=np.float64)
    end = np.array([b[0], b[1], z], dtype=np.float64)
    mujoco.mjv_connector(geom, kind, width, start, end)
