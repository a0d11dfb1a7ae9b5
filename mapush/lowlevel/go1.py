"""The `go1` low level: every robot is the 12-DoF Go1, walked by a learned locomotion policy (`level=locomotion`).

Each policy step (50 Hz) the backend builds every robot's proprioceptive observation (`proprioception`, the same
function the locomotion env trains on), runs the frozen locomotion policy on all E x A robots at once, and writes
joint targets for the PD servos, which run at every 5 ms physics step. Robots can fall (`tilt`), which the pushing
levels count as an exception.

The policy is a TorchScript `policy.pt` exported by `mapush train level=locomotion`: `lowlevel.policy=PATH`, or
`shipped:NAME` of one shipped in the package (`mapush/lowlevel/pretrained/NAME/`, slim run dirs written by
`mapush ship`), or null for `shipped:go1` (`policy_of`).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import mujoco
import numpy as np
import torch

from mapush.digests import verify
from mapush.errors import BadInput, first_line
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1_model import go1_spec
from mapush.rundir import SHIPPED_GO1, SHIPPED_LOWLEVEL, SHIPPED_PREFIX, shipped_run

PRETRAINED_RUN = SHIPPED_GO1
"""The shipped locomotion policy's run dir: its config, actor checkpoint, TorchScript policy and eval."""
PRETRAINED = PRETRAINED_RUN / "policy.pt"
"""The shipped locomotion policy (`lowlevel.policy: null`)."""

ANG_VEL_SCALE, JOINT_VEL_SCALE = 0.25, 0.05
"""Observation scales of the angular and joint velocities."""

PROPRIO_DIM = 45


def rotate_into_body(quat: np.ndarray, v: np.ndarray) -> np.ndarray:
    """World vectors v (..., 3) in the body frame of unit quaternions (..., 4) = (w, x, y, z): R(q)^T v."""
    w, xyz = quat[..., :1], quat[..., 1:]
    t = 2.0 * np.cross(xyz, v)
    return v - w * t + np.cross(xyz, t)


def rotate_into_world(quat: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body vectors v (..., 3) in the world frame: R(q) v."""
    w, xyz = quat[..., :1], quat[..., 1:]
    t = 2.0 * np.cross(xyz, v)
    return v + w * t + np.cross(xyz, t)


def proprioception(
    qpos: np.ndarray, qvel: np.ndarray, commands: np.ndarray, last_actions: np.ndarray, default_pose: np.ndarray
) -> np.ndarray:
    """What a Go1 senses, (..., 45): angular velocity x0.25 (body) | gravity direction (body) | command (vx, vy,
    yaw rate) | joint angles minus the standing pose | joint velocities x0.05 | the last actions.

    Args:
        qpos: (..., 19) free joint (position, quaternion) then the 12 joints. qvel: (..., 18) free joint
            (world linear, body angular velocity) then the joints. commands: (..., 3). last_actions: (..., 12).
    """
    quat = qpos[..., 3:7]
    down = np.broadcast_to(np.array([0.0, 0.0, -1.0]), (*quat.shape[:-1], 3))
    return np.concatenate(
        [
            qvel[..., 3:6] * ANG_VEL_SCALE,
            rotate_into_body(quat, down),
            commands,
            qpos[..., 7:] - default_pose,
            qvel[..., 6:] * JOINT_VEL_SCALE,
            last_actions,
        ],
        -1,
    )


def policy_of(cfg: dict) -> str:
    """The locomotion policy a Go1 config names: its `policy`, or the shipped one it was made for when null: a
    config without `torque_limits` predates the original-like Go1 and ran the stronger one (`shipped:go1_strong`)."""
    if cfg.get("policy"):
        return str(cfg["policy"])
    return f"{SHIPPED_PREFIX}go1" if "torque_limits" in cfg else f"{SHIPPED_PREFIX}go1_strong"


def locomotion_policy_file(path: str | Path | None) -> Path:
    """The file of the locomotion policy at `path` (a file, a run dir, `shipped:NAME` of a shipped Go1 policy, or
    None: `shipped:go1`); BadInput when there is none."""
    if str(path or "").startswith(SHIPPED_PREFIX):
        name = str(path)[len(SHIPPED_PREFIX) :]
        walkers = sorted(p.parent.name for p in SHIPPED_LOWLEVEL.glob("*/policy.pt"))
        if name not in walkers:
            raise BadInput(
                f"lowlevel.policy={path}: no such shipped Go1 policy; valid: shipped:{', shipped:'.join(walkers)}"
            )
        target = shipped_run(name)
    else:
        target = Path(path) if path else PRETRAINED
    if target.is_dir():
        target = target / "policy.pt"
    if not target.is_file():
        hint = "train one with `mapush train level=locomotion`, then lowlevel.policy=RUN_DIR/policy.pt"
        what = f"lowlevel.policy={str(path)!r} does not exist" if path else "no pretrained Go1 policy is shipped yet"
        raise BadInput(f"{what}; valid: a policy.pt of a level=locomotion run ({hint})")
    return target


def load_locomotion_policy(path: str | Path | None):
    """The TorchScript locomotion policy at `path` (None: the shipped one); BadInput when there is none."""
    target = locomotion_policy_file(path)
    verify(target)  # altered since exported or shipped: refused, not walked badly
    try:
        policy = torch.jit.load(str(target), map_location="cpu")
    except (RuntimeError, ValueError) as err:  # not a TorchScript archive
        first = first_line(err)
        raise BadInput(
            f"lowlevel.policy={str(target)!r} is not a TorchScript policy ({first}); valid: a policy.pt of a "
            "level=locomotion run"
        ) from None
    policy.eval()
    return policy


class Go1:
    """Legged Go1 robots walked by the locomotion policy; see the module docstring."""

    can_fall = True

    @staticmethod
    def check(cfg: dict) -> None:
        """BadInput unless the config's locomotion policy exists and loads (checked before anything is built)."""
        load_locomotion_policy(policy_of(cfg))

    @staticmethod
    def policy_fingerprint(cfg: dict) -> dict:
        """Which locomotion policy walks the robots: its file and the first 16 hex digits of its SHA-256 (an
        evaluation records it; a sweep re-evaluates when the shipped policy is replaced)."""
        path = locomotion_policy_file(policy_of(cfg))
        return {"file": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest()[:16]}

    def __init__(self, cfg: dict):
        self.cfg = cfg
        self.policy = load_locomotion_policy(policy_of(cfg))
        self.default_pose = np.array(go1.default_joint_angles())
        self.last_actions: np.ndarray | None = None  # (E, A, 12), made at the first place() or command()

    def robot_spec(self, rgba: tuple[float, float, float, float] = (0.2, 0.4, 0.9, 1.0)) -> mujoco.MjSpec:
        """One Go1 as a standalone spec, to be attached by prefix (`robot0/`, `robot1/`, ...)."""
        cfg = self.cfg
        return go1_spec(cfg["kp"], cfg["kd"], cfg.get("torque_limits"), foot_friction=cfg["foot_friction"], rgba=rgba)

    def seed(self, seed: int) -> None:
        """Nothing is drawn: a Go1 falls by its physics."""

    def after_step(self, dt: float) -> None:
        """Nothing to update: a Go1's fall is in its pose (`read`)."""

    def bind(self, model: mujoco.MjModel, prefixes: list[str], batch=None) -> None:
        """Find every robot's columns: `qpos_idx` (A, 19), `qvel_idx` (A, 18), `ctrl_idx` (A, 12)."""
        qpos, qvel, ctrl = [], [], []
        for p in prefixes:
            root = model.joint(p + go1.ROOT_JOINT).id
            joints = [model.joint(p + name).id for name in go1.JOINT_NAMES]
            qpos.append([model.jnt_qposadr[root] + k for k in range(7)] + [model.jnt_qposadr[j] for j in joints])
            qvel.append([model.jnt_dofadr[root] + k for k in range(6)] + [model.jnt_dofadr[j] for j in joints])
            ctrl.append([model.actuator(p + name.replace("_joint", "")).id for name in go1.JOINT_NAMES])
        self.qpos_idx, self.qvel_idx, self.ctrl_idx = np.array(qpos), np.array(qvel), np.array(ctrl)

    def _actions_for(self, num_envs: int) -> np.ndarray:
        if self.last_actions is None or len(self.last_actions) != num_envs:
            self.last_actions = np.zeros((num_envs, len(self.qpos_idx), 12))
        return self.last_actions

    def read(self, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """Robot states: `xy` (E, A, 2), `yaw` (E, A), `vel` (E, A, 3) = world (vx, vy, yaw rate), `tilt` (E, A)."""
        pose, vel = qpos[:, self.qpos_idx], qvel[:, self.qvel_idx]
        w, x, y, z = (pose[..., k] for k in range(3, 7))
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        yaw_rate = rotate_into_world(pose[..., 3:7], vel[..., 3:6])[..., 2]
        return {
            "xy": pose[..., :2],
            "yaw": yaw,
            "vel": np.concatenate([vel[..., :2], yaw_rate[..., None]], -1),
            "tilt": np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0)),
        }

    def command(self, ctrl: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, cmd: np.ndarray) -> None:
        """Walk every robot at its body-frame command (E, A, 3): the policy's joint targets into ctrl."""
        last = self._actions_for(len(qpos))
        obs = proprioception(qpos[:, self.qpos_idx], qvel[:, self.qvel_idx], cmd, last, self.default_pose)
        E, A, d = obs.shape
        with torch.inference_mode():
            actions = self.policy(torch.from_numpy(obs.reshape(E * A, d).astype(np.float32))).numpy()
        clip = self.cfg["action_clip"]
        self.last_actions = actions.reshape(E, A, 12).clip(-clip, clip).astype(np.float64)
        ctrl[:, self.ctrl_idx] = self.default_pose + self.cfg["action_scale"] * self.last_actions

    def place(self, qpos: np.ndarray, qvel: np.ndarray, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> None:
        """Stand the robots of envs `ids` at `xy` (n, A, 2) with headings `yaw` (n, A), at rest."""
        n, A = yaw.shape
        pose = np.zeros((n, A, 19))
        pose[..., :2] = xy
        pose[..., 2] = go1.standing_height() + 0.01
        pose[..., 3], pose[..., 6] = np.cos(yaw / 2), np.sin(yaw / 2)
        pose[..., 7:] = self.default_pose
        qpos[ids[:, None, None], self.qpos_idx[None]] = pose
        qvel[ids[:, None, None], self.qvel_idx[None]] = 0.0
        self._actions_for(len(qpos))[ids] = 0.0
