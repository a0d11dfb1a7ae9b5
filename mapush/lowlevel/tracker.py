"""The `tracker` low level: each robot is one rigid body moved in x, y and yaw by force-limited velocity actuators.

It stands for "a locomotion controller that tracks velocity commands" (docs/design.md). Each actuator
applies F = gain * (v_cmd - v), clamped to the force limit; with gain = mass / lag the velocity follows the command
as a first-order lag. The slide joints move along the world axes, so body-frame commands are rotated into the world
frame before they become actuator targets. The robot floats at a fixed height: it cannot tilt or fall.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mapush.errors import BadInput
from mapush.planning.geometry import rotate

ROBOT_BODY = "base"
RANDOMIZED = ("lag", "yaw_lag", "max_force")
"""The keys `randomize` may draw anew per robot in training (`Tracker.vary`)."""
JOINTS = ("x", "y", "yaw")
"""Joint names inside one robot, in qpos order: world-x slide, world-y slide, yaw hinge."""


class Tracker:
    """Velocity-tracking rigid-body robots; see the module docstring."""

    can_fall = False

    @staticmethod
    def check(cfg: dict) -> None:
        """BadInput unless every `randomize` range is a known key with 0 < low <= high (the tracker needs no files)."""
        for key, bounds in (cfg.get("randomize") or {}).items():
            if key not in RANDOMIZED:
                raise BadInput(f"lowlevel.randomize.{key} is not drawn; valid: {', '.join(RANDOMIZED)}")
            if bounds is not None and not (
                isinstance(bounds, list | tuple) and len(bounds) == 2 and 0 < float(bounds[0]) <= float(bounds[1])
            ):
                raise BadInput(
                    f"lowlevel.randomize.{key}={bounds} is not a range; valid: [low, high] with 0 < low <= high"
                )

    @staticmethod
    def policy_fingerprint(cfg: dict) -> None:
        """No policy walks the tracker's robots (`Go1.policy_fingerprint`)."""

    def __init__(self, cfg: dict):
        self.cfg = cfg
        length, width, _height = cfg["size"]
        self.yaw_inertia = cfg["mass"] * (length**2 + width**2) / 12.0

    def gains(self, lag, yaw_lag) -> tuple:
        """The velocity actuators' gains (x, y, yaw) that make a robot follow its commands with these lags, s:
        mass / lag on the slides, Izz / yaw_lag on the hinge (floats or arrays alike)."""
        return self.cfg["mass"] / lag, self.cfg["mass"] / lag, self.yaw_inertia / yaw_lag

    def robot_spec(self, rgba: tuple[float, float, float, float] = (0.2, 0.4, 0.9, 1.0)) -> mujoco.MjSpec:
        """One robot as a standalone spec, to be attached by prefix (`robot0/`, `robot1/`, ...)."""
        length, width, height = self.cfg["size"]
        spec = mujoco.MjSpec()
        body = spec.worldbody.add_body(name=ROBOT_BODY, pos=[0.0, 0.0, height / 2])
        for name, jtype, axis in (("x", "SLIDE", [1, 0, 0]), ("y", "SLIDE", [0, 1, 0]), ("yaw", "HINGE", [0, 0, 1])):
            body.add_joint(name=name, type=getattr(mujoco.mjtJoint, f"mjJNT_{jtype}"), axis=axis)
        # Robots touch the object, the walls and each other, never the floor (contype/conaffinity bit 2 only).
        body.add_geom(
            name="footprint",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[length / 2, width / 2, height / 2],
            mass=self.cfg["mass"],
            rgba=list(rgba),
            contype=2,
            conaffinity=2,
            friction=[self.cfg["friction"], 0.005, 0.0001],
        )
        # A nose marks the heading (visual only).
        body.add_geom(
            name="nose",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[0.05, 0, 0],
            pos=[length / 2, 0, height / 2],
            contype=0,
            conaffinity=0,
            mass=0.0,
            rgba=[1.0, 0.8, 0.1, 1.0],
        )
        limits = (self.cfg["max_force"], self.cfg["max_force"], self.cfg["max_torque"])
        for name, gain, limit in zip(JOINTS, self.gains(self.cfg["lag"], self.cfg["yaw_lag"]), limits, strict=True):
            act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_velocity(kv=gain)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-limit, limit]
        return spec

    def bind(self, model: mujoco.MjModel, prefixes: list[str]) -> None:
        """Find the qpos, qvel and ctrl columns of every robot. Sets `qpos_idx`, `qvel_idx`, `ctrl_idx`: (A, 3)."""
        joint_ids = np.array([[model.joint(p + j).id for j in JOINTS] for p in prefixes])
        self.qpos_idx = model.jnt_qposadr[joint_ids]
        self.qvel_idx = model.jnt_dofadr[joint_ids]
        self.ctrl_idx = np.array([[model.actuator(p + j).id for j in JOINTS] for p in prefixes])

    def read(self, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """Robot states of all envs: `xy` (E, A, 2), `yaw` (E, A), `vel` (E, A, 3) world frame, `tilt` (E, A)."""
        pose = qpos[:, self.qpos_idx]
        return {
            "xy": pose[..., :2],
            "yaw": pose[..., 2],
            "vel": qvel[:, self.qvel_idx],
            "tilt": np.zeros(pose.shape[:2]),
        }

    def command(self, ctrl: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, cmd: np.ndarray) -> None:
        """Write body-frame commands (E, A, 3) = (vx, vy, yaw rate) as world-frame actuator targets into ctrl."""
        yaw = qpos[:, self.qpos_idx[:, 2]]
        world = np.concatenate([rotate(cmd[..., :2], yaw), cmd[..., 2:3]], -1)
        ctrl[:, self.ctrl_idx] = world

    def vary(self, batch, ids: np.ndarray, rng: np.random.Generator) -> None:
        """Draw the robots' `lag`, `yaw_lag` and `max_force` of envs `ids` uniformly from `randomize`'s ranges (one
        draw per robot) and write them into the batch's per-env actuator gains and force limits."""
        ranges = self.cfg["randomize"]
        n, A = len(ids), self.ctrl_idx.shape[0]

        def draw(key: str) -> np.ndarray:
            return rng.uniform(*ranges.get(key) or [self.cfg[key]] * 2, size=(n, A))

        lag, yaw_lag, force = draw("lag"), draw("yaw_lag"), draw("max_force")
        gain, bias, limit = (
            batch.expand(name) for name in ("actuator_gainprm", "actuator_biasprm", "actuator_forcerange")
        )
        kv = np.stack(self.gains(lag, yaw_lag), -1)  # (n, A, 3)
        rows = ids[:, None, None]
        gain[rows, self.ctrl_idx, 0] = kv
        bias[rows, self.ctrl_idx, 2] = -kv
        limit[rows, self.ctrl_idx[:, :2]] = np.stack([-force, force], -1)[:, :, None, :]  # both slides

    def place(self, qpos: np.ndarray, qvel: np.ndarray, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> None:
        """Put the robots of envs `ids` at `xy` (n, A, 2) with headings `yaw` (n, A), at rest."""
        qpos[np.ix_(ids, self.qpos_idx[:, 0])] = xy[..., 0]
        qpos[np.ix_(ids, self.qpos_idx[:, 1])] = xy[..., 1]
        qpos[np.ix_(ids, self.qpos_idx[:, 2])] = yaw
        qvel[np.ix_(ids, self.qvel_idx.reshape(-1))] = 0.0
