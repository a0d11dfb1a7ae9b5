"""The pushing scene on the simulation core: an object, A robots driven by a low-level backend, a subgoal marker
and optional obstacle blocks, E copies stepped together (`BatchSim`). Its state comes out as a `PushState`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from mapush.sim.batch import BatchSim
from mapush.sim.scene import OBJECT_BODY, OBJECT_JOINT, OBSTACLE_BODY, SUBGOAL_BODY, build_scene, robot_prefixes


@dataclass
class PushState:
    """What the pushing scene is now, float32 tensors over envs E and robots A (world frame, m, rad, s).

    Written by `PushSim.read` after every physics step and reset; the observation, reward and exception terms
    read it as `env.state`.
    """

    object_xy: torch.Tensor  # (E, 2) centre
    object_z: torch.Tensor  # (E,) height of the centre
    object_yaw: torch.Tensor  # (E,)
    object_tilt: torch.Tensor  # (E,) angle of the body z axis from upright
    object_vel: torch.Tensor  # (E, 3) vx, vy, yaw rate
    robot_xy: torch.Tensor  # (E, A, 2)
    robot_yaw: torch.Tensor  # (E, A)
    robot_vel: torch.Tensor  # (E, A, 3) as the backend reports it
    robot_tilt: torch.Tensor  # (E, A) roll or pitch from upright
    robot_distance: torch.Tensor  # (E, A, A) between robot centres, diagonal 0


class PushSim(BatchSim):
    """E pushing scenes with a low-level backend driving the robots.

    Args:
        sim_cfg: the `sim` config block.
        task_cfg: the task config.
        lowlevel: a low-level backend instance (e.g. `Tracker`).
        num_envs: number of parallel envs E.
        obstacles: obstacle blocks per scene (mocap bodies, placed by `set_obstacles`).
        obstacle_size: their (x, y, z) size, m.
    """

    def __init__(
        self, sim_cfg: dict, task_cfg: dict, lowlevel, num_envs: int, obstacles: int = 0, obstacle_size=(1.0, 1.0, 1.0)
    ):
        self.spec = build_scene(sim_cfg, task_cfg, lowlevel, obstacles, obstacle_size)
        super().__init__(self.spec.compile(), num_envs, sim_cfg["decimation"], sim_cfg["nthread"])
        self.num_agents = task_cfg["num_agents"]
        self.lowlevel = lowlevel
        self.mocap_pos = self.batch.bind("mocap_pos")
        lowlevel.bind(self.model, robot_prefixes(self.num_agents), self.batch)
        joint = self.model.joint(OBJECT_JOINT)
        self.object_qpos = int(self.model.jnt_qposadr[joint.id])
        self.object_qvel = int(self.model.jnt_dofadr[joint.id])
        self.subgoal_mocap = int(self.model.body(SUBGOAL_BODY).mocapid[0])
        self.obstacle_mocap = np.array(
            [int(self.model.body(OBSTACLE_BODY.format(k)).mocapid[0]) for k in range(obstacles)], dtype=np.int64
        )
        self.mocap_quat = self.batch.bind("mocap_quat")
        self.obstacle_height = float(obstacle_size[2])
        self.object_geoms = np.flatnonzero(self.model.geom_bodyid == self.model.body(OBJECT_BODY).id)
        self.object_rest_z = float(self.model.body(OBJECT_BODY).pos[2])
        self.geom_friction = self.batch.expand("geom_friction")
        self.object_body = int(self.model.body(OBJECT_BODY).id)
        self.object_mass = None  # per-env body mass and inertia, made at the first layout that sets a `mass`
        self.batch.reset()

    def step(self, commands: torch.Tensor, substep=None) -> np.ndarray:
        """Apply body-frame commands (E, A, 3) for one policy step; returns the env ids that failed (`advance`, which
        calls `substep()` after every physics step when given)."""
        self.lowlevel.command(self.ctrl, self.qpos, self.qvel, commands.numpy().astype(np.float64))
        failed = self.advance(substep)
        self.lowlevel.after_step(self.dt)
        return failed

    def read(self) -> PushState:
        """The current state of every env (`PushState`)."""
        q = self.qpos[:, self.object_qpos : self.object_qpos + 7]
        v = self.qvel[:, self.object_qvel : self.object_qvel + 6]
        w, x, y, z = q[:, 3], q[:, 4], q[:, 5], q[:, 6]
        # yaw of the quaternion; tilt = angle between the body z axis and world z: cos(tilt) = 1 - 2(x^2 + y^2)
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        tilt = np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))
        robots = self.lowlevel.read(self.qpos, self.qvel)
        arrays = {
            "object_xy": q[:, :2],
            "object_z": q[:, 2],
            "object_yaw": yaw,
            "object_tilt": tilt,
            "object_vel": np.concatenate([v[:, :2], v[:, 5:6]], axis=1),
            "robot_xy": robots["xy"],
            "robot_yaw": robots["yaw"],
            "robot_vel": robots["vel"],
            "robot_tilt": robots["tilt"],
        }
        out = {k: torch.from_numpy(np.ascontiguousarray(a, dtype=np.float32)) for k, a in arrays.items()}
        xy = out["robot_xy"]  # torch.cdist is ~100x slower at this size
        out["robot_distance"] = torch.linalg.vector_norm(xy.unsqueeze(2) - xy.unsqueeze(1), dim=-1)
        return PushState(**out)

    def reset(self, ids: np.ndarray, layout: dict[str, torch.Tensor]) -> None:
        """Reset envs `ids` to a sampled layout and redraw their object friction.

        Args:
            ids: env ids, (n,).
            layout: `object_xy` (n, 2), `object_yaw` (n,), `robot_xy` (n, A, 2), `robot_yaw` (n, A),
                `subgoal_xy` (n, 2), `friction` (n,), and optionally `mass` (n,): the object's, kg (its inertia
                scaled with it; without it the model's).
        """
        if len(ids) == 0:
            return
        lay = {k: v.numpy().astype(np.float64) for k, v in layout.items()}
        self.restart(ids)
        half_yaw = lay["object_yaw"] / 2
        obj = np.zeros((len(ids), 7))
        obj[:, :2] = lay["object_xy"]
        obj[:, 2] = self.object_rest_z
        obj[:, 3], obj[:, 6] = np.cos(half_yaw), np.sin(half_yaw)
        self.qpos[ids, self.object_qpos : self.object_qpos + 7] = obj
        self.lowlevel.place(self.qpos, self.qvel, ids, lay["robot_xy"], lay["robot_yaw"])
        self.mocap_pos[ids, self.subgoal_mocap, :2] = lay["subgoal_xy"]
        self.geom_friction[np.ix_(ids, self.object_geoms, [0])] = lay["friction"][:, None, None]
        if "mass" in lay:
            self.set_object_mass(ids, lay["mass"])
        self.forward(ids)

    def set_object_mass(self, ids: np.ndarray, mass: np.ndarray) -> None:
        """The object of envs `ids` weighs `mass` (n,) kg; its inertia scales with it (the same shape), and the
        model's derived constants follow."""
        if self.object_mass is None:
            self.object_mass, self.object_inertia = self.batch.expand("body_mass"), self.batch.expand("body_inertia")
        body = self.object_body
        self.object_mass[ids, body] = mass
        self.object_inertia[ids, body] = self.model.body_inertia[body] * (mass / self.model.body_mass[body])[:, None]
        self.batch.set_const(ids)  # the constants derived from masses (e.g. the contacts' inverse weights)

    def object_masses(self) -> np.ndarray:
        """The object's mass in each env, kg (E,): as `set_object_mass` set it, else the model's."""
        if self.object_mass is None:
            return np.full(self.num_envs, self.model.body_mass[self.object_body])
        return self.object_mass[:, self.object_body]

    def set_obstacles(self, ids: np.ndarray, obstacles: torch.Tensor) -> None:
        """Place the obstacle blocks of envs `ids`: rows (n, K, 5) of (x, y, yaw, size x, size y); sizes are fixed."""
        rows = obstacles.numpy().astype(np.float64)
        idx = np.ix_(ids, self.obstacle_mocap)
        pos = np.zeros((len(ids), len(self.obstacle_mocap), 3))
        pos[..., :2], pos[..., 2] = rows[..., :2], self.obstacle_height / 2
        quat = np.zeros((len(ids), len(self.obstacle_mocap), 4))
        quat[..., 0], quat[..., 3] = np.cos(rows[..., 2] / 2), np.sin(rows[..., 2] / 2)
        self.mocap_pos[idx] = pos
        self.mocap_quat[idx] = quat

    def set_subgoal(self, ids: np.ndarray, xy: torch.Tensor) -> None:
        """Move the (visual) subgoal marker of envs `ids` to `xy` (n, 2)."""
        self.mocap_pos[ids, self.subgoal_mocap, :2] = xy.numpy()
