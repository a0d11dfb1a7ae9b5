"""What disturbs the Go1 of the locomotion env (`level=low`), beside its commands: a random push every
`push_interval_s`, a free load ahead of it along its first command, teammates beside it that lean into it. The
env's own randomization (friction, mass) and its step are in `low.py`; the scene with the loads and teammates in
`mapush/lowlevel/go1_training_scene.py`."""

from __future__ import annotations

import math

import numpy as np
import torch

from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import Go1, rotate_into_world
from mapush.lowlevel.go1_training_scene import LOAD_BODIES, MATE_PARKED_XY, MATE_PREFIX, PARKED_XY, teammate_count
from mapush.planning.geometry import rotate


class Disturbances:
    """The locomotion env's disturbances, as methods of `LocomotionEnv` (they read and write its state)."""

    def _bind_teammates(self) -> None:
        """The teammates' backend `mates` (a go1 backend walking them with the frozen locomotion policy; None
        without teammates) and their parked places (k, 2). `mate_used` (E,) says which envs' episodes have them,
        `lean` (E,) each env's lean toward the robot, m/s."""
        k = teammate_count(self.cfg)
        self.mates = Go1(self.cfg["lowlevel"]) if k else None
        if self.mates:
            self.mates.bind(self.model, [MATE_PREFIX.format(i) for i in range(k)])
        self.mate_parked = np.array([[MATE_PARKED_XY[0] + i, MATE_PARKED_XY[1]] for i in range(k)])
        self.mate_used = np.zeros(self.num_envs, dtype=bool)
        self.lean = np.zeros(self.num_envs)

    def _place_loads(self, ids: np.ndarray, yaw: np.ndarray, commands: np.ndarray) -> None:
        """A `load_fraction` of the episodes get one load, box or cylinder, at a random yaw, U(distance_m) ahead of
        the trunk (to the cylinder's side, or the circle round the box's corners) along the commanded velocity (any
        way for a command to stand or turn). The other load, and both in the other episodes, wait parked."""
        load, n = self.cfg["level"]["randomize"]["load"], len(ids)
        heading = yaw + np.arctan2(commands[:, 1], commands[:, 0])
        still = np.linalg.norm(commands[:, :2], axis=1) < 0.1
        heading[still] = self.rng.uniform(-math.pi, math.pi, size=int(still.sum()))
        used = np.where(self.rng.random(n) < self.load_fraction, self.rng.integers(len(self.loads), size=n), -1)
        gap = self.rng.uniform(*load["distance_m"], size=n)
        spin = self.rng.uniform(-math.pi, math.pi, size=n)
        reach = {"box": math.hypot(*load["box_size_m"][:2]) / 2, "cylinder": load["cylinder_size_m"][0]}
        for k, (shape, body) in enumerate(zip(LOAD_BODIES, self.loads, strict=True)):
            address = self.model.jnt_qposadr[body.jntadr[0]]
            here = used == k
            centre = go1.TRUNK_SIZE[0] / 2 + gap + reach[shape]  # a box's corner at most `gap` away, its side further
            ahead = centre[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)
            xy = np.where(here[:, None], ahead, PARKED_XY[shape])
            pose = np.zeros((n, 7))
            pose[:, :2], pose[:, 2] = xy, self.model.body_pos[body.id][2]
            pose[:, 3], pose[:, 6] = np.cos(spin / 2), np.sin(spin / 2)
            self.sim.qpos[ids, address : address + 7] = pose

    def _place_teammates(self, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> None:
        """A `teammate_fraction` of the episodes start with every teammate standing beside the robot, alternately
        on its left and right (the third and fourth one robot-length and `row_gap_m` further back), `gap_m` from
        its side, `along_m` ahead or behind, headed as it within `heading_rad`, each env with its own lean
        (`lean_mps`); in the others they stand parked."""
        mates, n, k = self.cfg["level"]["randomize"]["teammates"], len(ids), len(self.mate_parked)
        used = self.rng.random(n) < self.teammate_fraction
        self.mate_used[ids] = used
        self.lean[ids] = np.where(used, self.rng.uniform(*mates["lean_mps"], size=n), 0.0)
        length, width = self.robot["size"][:2]
        side = np.where(np.arange(k) % 2 == 0, 1.0, -1.0)  # (k,) left, right, ...
        lateral = side * (width + self.rng.uniform(*mates["gap_m"], size=(n, k)))
        along = -(length + mates["row_gap_m"]) * (np.arange(k) // 2) + self.rng.uniform(*mates["along_m"], size=(n, k))
        cos, sin = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        offset = np.stack([cos * along - sin * lateral, sin * along + cos * lateral], -1)  # (n, k, 2)
        placed = np.where(used[:, None, None], xy[:, None, :] + offset, self.mate_parked[None])
        turn = self.rng.uniform(-mates["heading_rad"], mates["heading_rad"], size=(n, k))
        heading = np.where(used[:, None], yaw[:, None] + turn, 0.0)
        self.mates.place(self.sim.qpos, self.sim.qvel, ids, placed, heading)

    def _drive_teammates(self) -> None:
        """Every teammate in use walks at the robot's commanded velocity (world frame, from the robot's heading now)
        plus its env's lean toward the robot; parked ones stand. Their policy writes their joint targets."""
        qpos, qvel = self.sim.qpos, self.sim.qvel
        command = np.concatenate([self.commands[:, :2].numpy(), np.zeros((self.num_envs, 1))], -1)
        walk = rotate_into_world(self.robot_qpos[:, 3:7], command)[:, None, :2]  # (E, 1, 2)
        mates = self.mates.read(qpos, qvel)
        toward = self.robot_qpos[:, None, :2] - mates["xy"]
        toward /= np.maximum(np.linalg.norm(toward, axis=-1, keepdims=True), 1e-6)
        velocity = (walk + self.lean[:, None, None] * toward) * self.mate_used[:, None, None]  # (E, k, 2) world
        body = rotate(velocity, mates["yaw"], inverse=True)  # into each teammate's frame
        self.mates.command(self.sim.ctrl, qpos, qvel, np.concatenate([body, np.zeros_like(body[..., :1])], -1))

    def _every(self, seconds: float) -> torch.Tensor:
        """(E,) envs whose episode is at a multiple of `seconds` (at least one step) this step."""
        return self.episode_step % max(1, round(seconds / self.dt)) == 0

    def _push(self) -> None:
        """Every `push_interval_s`, a random change of each robot's horizontal velocity (m/s)."""
        rand = self.cfg["level"]["randomize"]
        due = self._every(rand["push_interval_s"]).numpy()
        if self.push_velocity > 0 and due.any():
            ids = np.flatnonzero(due)
            self.sim.qvel[ids, 0:2] += self.rng.uniform(-1, 1, size=(len(ids), 2)) * self.push_velocity

    def _lean(self) -> None:
        """Every `force_interval_s`, a horizontal force on each trunk of size U(0, `force_n`) N in a random
        direction, held `force_duration_s`: the sustained load of pushing an object or being leaned on, which the
        velocity pushes (`_push`) do not give."""
        if self.force_n <= 0:
            return
        rand = self.cfg["level"]["randomize"]
        self.force_steps_left -= 1
        self.applied[self.force_steps_left == 0, self.trunk, :2] = 0.0
        due = self._every(rand["force_interval_s"]).numpy()
        if due.any():
            ids = np.flatnonzero(due)
            size = self.rng.uniform(0.0, self.force_n, size=len(ids))
            heading = self.rng.uniform(-math.pi, math.pi, size=len(ids))
            self.applied[ids, self.trunk, 0] = size * np.cos(heading)
            self.applied[ids, self.trunk, 1] = size * np.sin(heading)
            self.force_steps_left[ids] = max(1, round(rand["force_duration_s"] / self.dt))
