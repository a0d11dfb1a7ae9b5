"""The batched simulation core: E copies of one scene stepped together by `mujoco.batch.Batch` on every core.

It owns the MuJoCo side only: live state arrays, named indices, per-env friction, partial resets, and stepping.
Everything it returns is a float32 torch tensor over envs (and agents); the env logic lives in `mapush.envs`.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np
import torch
from mujoco import batch as mjb

from mapush.sim.scene import OBJECT_BODY, OBJECT_JOINT, OBSTACLE_BODY, SUBGOAL_BODY, build_scene, robot_prefixes


class BatchSim:
    """E pushing scenes on `mujoco.batch`, with a low-level backend driving the robots.

    Args:
        sim_cfg: the `sim` config block.
        task_cfg: the task config.
        lowlevel: a low-level backend instance (e.g. `Tracker`).
        num_envs: number of parallel envs E.
    """

    def __init__(
        self, sim_cfg: dict, task_cfg: dict, lowlevel, num_envs: int, obstacles: int = 0, obstacle_size=(1.0, 1.0, 1.0)
    ):
        self.spec = build_scene(sim_cfg, task_cfg, lowlevel, obstacles, obstacle_size)
        self.model = self.spec.compile()
        self.num_envs = num_envs
        self.num_agents = task_cfg["num_agents"]
        self.decimation = sim_cfg["decimation"]
        self.lowlevel = lowlevel
        nthread = sim_cfg["nthread"] or os.cpu_count() or 1
        self.batch = mjb.Batch(self.model, nsim=num_envs, nthread=min(nthread, num_envs))
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.ctrl, self.mocap_pos = self.batch.bind("ctrl"), self.batch.bind("mocap_pos")
        lowlevel.bind(self.model, robot_prefixes(self.num_agents))
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
        self.batch.reset()

    @property
    def dt(self) -> float:
        """Policy step, s: timestep * decimation."""
        return float(self.model.opt.timestep) * self.decimation

    def step(self, commands: torch.Tensor) -> np.ndarray:
        """Apply body-frame commands (E, A, 3) for one policy step.

        Returns:
            Env ids whose simulation failed (diverged); their state is left for the caller to reset. Shape: (n,).
        """
        self.lowlevel.command(self.ctrl, self.qpos, self.qvel, commands.numpy().astype(np.float64))
        try:
            self.batch.step(nstep=self.decimation)
        except mjb.SimulationError as err:
            return np.asarray(err.ids, dtype=np.int64)
        return np.empty(0, dtype=np.int64)

    def read(self) -> dict[str, torch.Tensor]:
        """Current state of every env as float32 tensors.

        Returns:
            `object_xy` (E, 2), `object_z` (E,), `object_yaw` (E,), `object_tilt` (E,) rad from upright,
            `object_vel` (E, 3) = (vx, vy, yaw rate) world frame, `robot_xy` (E, A, 2), `robot_yaw` (E, A),
            `robot_vel` (E, A, 3), `robot_tilt` (E, A).
        """
        q = self.qpos[:, self.object_qpos : self.object_qpos + 7]
        v = self.qvel[:, self.object_qvel : self.object_qvel + 6]
        w, x, y, z = q[:, 3], q[:, 4], q[:, 5], q[:, 6]
        # yaw of the quaternion; tilt = angle between the body z axis and world z: cos(tilt) = 1 - 2(x^2 + y^2)
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        tilt = np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))
        robots = self.lowlevel.read(self.qpos, self.qvel)
        out = {
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
        return {k: torch.from_numpy(np.ascontiguousarray(a, dtype=np.float32)) for k, a in out.items()}

    def reset(self, ids: np.ndarray, layout: dict[str, torch.Tensor]) -> None:
        """Reset envs `ids` to a sampled layout and redraw their object friction.

        Args:
            ids: env ids, (n,).
            layout: `object_xy` (n, 2), `object_yaw` (n,), `robot_xy` (n, A, 2), `robot_yaw` (n, A),
                `subgoal_xy` (n, 2), `friction` (n,).
        """
        if len(ids) == 0:
            return
        lay = {k: v.numpy().astype(np.float64) for k, v in layout.items()}
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)
        half_yaw = lay["object_yaw"] / 2
        obj = np.zeros((len(ids), 7))
        obj[:, :2] = lay["object_xy"]
        obj[:, 2] = self.object_rest_z
        obj[:, 3], obj[:, 6] = np.cos(half_yaw), np.sin(half_yaw)
        self.qpos[ids, self.object_qpos : self.object_qpos + 7] = obj
        self.lowlevel.place(self.qpos, self.qvel, ids, lay["robot_xy"], lay["robot_yaw"])
        self.mocap_pos[ids, self.subgoal_mocap, :2] = lay["subgoal_xy"]
        self.geom_friction[np.ix_(ids, self.object_geoms, [0])] = lay["friction"][:, None, None]
        self.batch.forward(ids)

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
