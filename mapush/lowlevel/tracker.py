"""The `tracker` low level: each robot is one rigid body moved in x, y and yaw by force-limited velocity actuators.

It stands for "a locomotion controller that tracks velocity commands" (docs/design.md). Each actuator
applies F = gain * (v_cmd - v), clamped to the force limit; with gain = mass / lag the velocity follows the command
as a first-order lag. The slide joints move along the world axes, so body-frame commands are rotated into the world
frame before they become actuator targets. The robot floats at a fixed height.

Two limits stand for the legged Go1's, as `mapush calibrate` measures them (docs/fidelity.md):
- `force_cap: planar`: `max_force` caps the norm of the planar push, in every direction. At each policy step the
  x and y actuators get the limits max_force * |e_x| / |e| and max_force * |e_y| / |e|, where e is the velocity
  error: the box they make has its corner on the circle of radius max_force, so no force leaves that circle, and
  a push along e reaches it. Runs made before the key capped each world axis at `max_force` (`axes`).
- `fall`: a robot that holds a load its Go1 could not falls. The load is the planar contact force on the robot
  (`qfrc_constraint` of its slides), low-passed over `filter_s`. The Go1 under a held load L falls within
  `window_s` with the measured probability P(L) = 1 / (1 + exp(-(L - load_n) / width_n)); so a robot falls at the
  hazard rate -ln(1 - P(L)) / window_s, against a threshold drawn per episode from Exp(1). A fallen robot reads as
  tilted by pi / 2, which the pushing levels' `robot_tilt` exception ends the episode on, as a Go1's fall.
  A held load cannot tell a robot holding a heavy object (a Go1 stands) from one that teammates shove back through
  the object (a Go1 falls): both read its cap. With `shove_mps` and `shove_shape`, a second hazard adds to the
  first: the *shove speed* u, the robot's speed against its commanded direction while its contacts drive it (their
  net force, above `DRIVEN_N`, has a component along its velocity; any nonzero command gives a direction, however
  small, and an exact zero none), low-passed over `filter_s`, gives the probability of a fall
  within `window_s` P(u) = 1 - exp(-(u / shove_mps) ** shove_shape), fitted to the Go1's falls when shoved
  (`mapush/calibration/squeeze.py`): a hazard rate (u / shove_mps) ** shove_shape / window_s, none for a robot
  not shoved. Runs made before the keys have no shove hazard.
  With `held_n` and `held_width_n`, a third hazard reads the planar force *applied* to the robot's body (MuJoCo's
  `xfrc_applied`, as `mapush calibrate` holds a load on a trunk), low-passed alike, through the Go1's own fall
  curve under a held load, P(L) = 1 / (1 + exp(-(L - held_n) / held_width_n)): the Go1 bears a load held back on
  its trunk less well than one at its nose, so the tracker, whose contacts all read as one load, keeps the two
  apart. No pushing env applies such a force; the channel makes the tracker fall in the calibration's held-load
  test as its Go1 does (`mapush.calibration.consistency`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mapush.errors import BadInput
from mapush.planning.geometry import rotate

ROBOT_BODY = "base"
FALLEN_TILT = np.pi / 2
"""rad; how a fallen robot reads (`read`): beyond every level's `robot_tilt` threshold."""
FALL_STREAM = 1
"""The fall thresholds draw from the seed's stream 1, apart from the env's own draws (stream 0: the plain seed)."""
MAX_FALL_PROBABILITY = 1.0 - 1e-9
"""P(L) is held below 1 so that the hazard stays finite."""
FORCE_CAPS = ("planar", "axes")
"""`force_cap`: on the norm of the planar force, or on each world axis (runs made before the key)."""
FALL_KEYS = ("load_n", "width_n", "window_s", "filter_s")
"""`fall`'s keys: the fitted fall curve (N, N, s) and the load's low-pass time constant (s)."""
SHOVE_KEYS = ("shove_mps", "shove_shape")
"""`fall`'s optional keys, both or neither: the fitted shove curve's scale (m/s) and shape (none)."""
HELD_KEYS = ("held_n", "held_width_n")
"""`fall`'s optional keys, both or neither: the Go1's fall curve under a load held on its trunk (N, N)."""
DRIVEN_N = 1.0
"""N; a net contact force below this does not drive a robot (contact noise at rest)."""
RANDOMIZED = ("lag", "yaw_lag", "max_force")
"""The keys `randomize` may draw anew per robot in training (`Tracker.vary`)."""
JOINTS = ("x", "y", "yaw")
"""Joint names inside one robot, in qpos order: world-x slide, world-y slide, yaw hinge."""


class Tracker:
    """Velocity-tracking rigid-body robots; see the module docstring."""

    @staticmethod
    def check(cfg: dict) -> None:
        """BadInput unless `force_cap`, `fall` and every `randomize` range are valid (the tracker needs no files)."""
        if cfg.get("force_cap", "axes") not in FORCE_CAPS:
            raise BadInput(f"lowlevel.force_cap={cfg['force_cap']!r}; valid: {', '.join(FORCE_CAPS)}")
        fall = cfg.get("fall")
        if fall is not None:
            keys = set(fall) if isinstance(fall, dict) else set()
            extra = keys - set(FALL_KEYS)
            wrong = not set(FALL_KEYS) <= keys or any(
                bool(extra & set(pair)) and not set(pair) <= extra for pair in (SHOVE_KEYS, HELD_KEYS)
            )
            wrong = wrong or not extra <= set(SHOVE_KEYS) | set(HELD_KEYS)
            numbers = not wrong and all(isinstance(fall[k], int | float) for k in keys)
            positive = ("width_n", "window_s", "filter_s", "held_width_n", *SHOVE_KEYS)
            if not numbers or not all(float(fall[k]) > 0 for k in positive if k in keys):
                raise BadInput(
                    f"lowlevel.fall={fall}: keys {', '.join(FALL_KEYS)}, optionally with {', '.join(SHOVE_KEYS)} "
                    f"and with {', '.join(HELD_KEYS)} (width_n, window_s, filter_s, held_width_n, "
                    f"{', '.join(SHOVE_KEYS)} > 0), or null"
                )
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
        self.planar = cfg.get("force_cap", "axes") == "planar"
        self.fall = cfg.get("fall")
        self.shoves = self.fall is not None and SHOVE_KEYS[0] in self.fall
        self.held_channel = self.fall is not None and HELD_KEYS[0] in self.fall
        self.rng = np.random.default_rng([0, FALL_STREAM])
        self.cap: np.ndarray | None = None  # (E, A) N, each robot's planar force cap (`planar`)

    @property
    def can_fall(self) -> bool:
        """Whether robots can fall: with a `fall` model."""
        return self.fall is not None

    def seed(self, seed: int) -> None:
        """Reseed the fall thresholds' draws."""
        self.rng = np.random.default_rng([int(seed), FALL_STREAM])

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

    def bind(self, model: mujoco.MjModel, prefixes: list[str], batch=None) -> None:
        """Find the qpos, qvel and ctrl columns of every robot (`qpos_idx`, `qvel_idx`, `ctrl_idx`: (A, 3)), and in
        `batch` (a `mujoco.batch.Batch`) the per-env force limits and contact forces the two limits need."""
        joint_ids = np.array([[model.joint(p + j).id for j in JOINTS] for p in prefixes])
        self.qpos_idx = model.jnt_qposadr[joint_ids]
        self.qvel_idx = model.jnt_dofadr[joint_ids]
        self.ctrl_idx = np.array([[model.actuator(p + j).id for j in JOINTS] for p in prefixes])
        if batch is None:
            return
        E, A = batch.nsim, len(prefixes)
        if self.planar:
            self.forcerange = batch.expand("actuator_forcerange")
            self.cap = np.full((E, A), float(self.cfg["max_force"]))
        if self.held_channel:
            self.applied = batch.bind("xfrc_applied")
            self.bodies = np.array([model.body(p + ROBOT_BODY).id for p in prefixes])
            self.held = np.zeros((E, A))  # N, the low-passed planar force applied to each body
        if self.fall is not None:
            self.constraint, self.qvel = batch.bind("qfrc_constraint"), batch.bind("qvel")
            self.load = np.zeros((E, A))  # N, the low-passed planar contact force
            self.shove = np.zeros((E, A))  # m/s, the low-passed shove speed (`shove_speed`)
            self.commanded = np.zeros((E, A, 2))  # m/s, the planar command in the world frame
            self.hazard = np.zeros((E, A))  # the hazard accumulated this episode
            self.threshold = np.ones((E, A))  # the hazard at which each robot falls, Exp(1) per episode
            self.fallen = np.zeros((E, A), dtype=bool)

    def fall_probability(self, load: np.ndarray) -> np.ndarray:
        """P(L): the fitted probability that the Go1 falls within `window_s` under a held load L (N)."""
        f = self.fall
        z = (np.asarray(load, dtype=np.float64) - f["load_n"]) / f["width_n"]
        return np.minimum(1.0 / (1.0 + np.exp(-np.clip(z, -60.0, 60.0))), MAX_FALL_PROBABILITY)

    def load_rate(self, load: np.ndarray, midpoint: str = "load_n", width: str = "width_n") -> np.ndarray:
        """The fall hazard rate (1/s) of a contact load L (N): -ln(1 - P(L)) / window_s; with `midpoint` and
        `width` naming `fall`'s held-load keys, of a load applied to the body."""
        f = self.fall
        z = (np.asarray(load, dtype=np.float64) - f[midpoint]) / f[width]
        p = np.minimum(1.0 / (1.0 + np.exp(-np.clip(z, -60.0, 60.0))), MAX_FALL_PROBABILITY)
        return -np.log1p(-p) / f["window_s"]

    def shove_speed(self, force: np.ndarray) -> np.ndarray:
        """(E, A) m/s: each robot's speed against its commanded planar direction while its contacts, net planar force
        `force` (E, A, 2), drive it (a positive component along its velocity); 0 otherwise, and for a zero command."""
        vel = self.qvel[:, self.qvel_idx[:, :2]]
        norm = np.linalg.norm(self.commanded, axis=-1)
        against = -(vel * self.commanded).sum(-1) / np.maximum(norm, 1e-9)
        driven = ((force * vel).sum(-1) > 0) & (np.linalg.norm(force, axis=-1) > DRIVEN_N) & (norm > 1e-9)
        return np.where(driven, np.maximum(against, 0.0), 0.0)

    def after_step(self, dt: float) -> None:
        """After a policy step of `dt` s: low-pass each robot's planar contact load (and shove speed) and accumulate
        its fall hazard; a robot whose hazard reaches its threshold has fallen (it stays fallen until `place`)."""
        if self.fall is None:
            return
        f, blend = self.fall, min(1.0, dt / self.fall["filter_s"])
        force = self.constraint[:, self.qvel_idx[:, :2]]  # (E, A, 2), read once for both hazards
        self.load += (np.linalg.norm(force, axis=-1) - self.load) * blend
        rate = self.load_rate(self.load)
        if self.held_channel:
            self.held += (np.linalg.norm(self.applied[:, self.bodies, :2], axis=-1) - self.held) * blend
            rate = rate + self.load_rate(self.held, *HELD_KEYS)
        if self.shoves:
            self.shove += (self.shove_speed(force) - self.shove) * blend
            rate = rate + (self.shove / f["shove_mps"]) ** f["shove_shape"] / f["window_s"]
        self.hazard += rate * dt
        self.fallen |= self.hazard >= self.threshold

    def read(self, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """Robot states of all envs: `xy` (E, A, 2), `yaw` (E, A), `vel` (E, A, 3) world frame, `tilt` (E, A)."""
        pose = qpos[:, self.qpos_idx]
        return {
            "xy": pose[..., :2],
            "yaw": pose[..., 2],
            "vel": qvel[:, self.qvel_idx],
            "tilt": self.fallen * FALLEN_TILT if self.fall is not None else np.zeros(pose.shape[:2]),
        }

    def command(self, ctrl: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, cmd: np.ndarray) -> None:
        """Write body-frame commands (E, A, 3) = (vx, vy, yaw rate) as world-frame actuator targets into ctrl."""
        yaw = qpos[:, self.qpos_idx[:, 2]]
        world = np.concatenate([rotate(cmd[..., :2], yaw), cmd[..., 2:3]], -1)
        ctrl[:, self.ctrl_idx] = world
        if self.fall is not None:
            self.commanded[:] = world[..., :2]
        if self.planar:
            error = world[..., :2] - qvel[:, self.qvel_idx[:, :2]]  # (E, A, 2)
            norm = np.linalg.norm(error, axis=-1, keepdims=True)
            share = np.where(norm > 1e-9, np.abs(error) / np.maximum(norm, 1e-12), np.sqrt(0.5))
            limit = self.cap[..., None] * share  # (E, A, 2): the box's corner on the circle of radius cap
            slides = self.ctrl_idx[:, :2]
            self.forcerange[:, slides, 0] = -limit
            self.forcerange[:, slides, 1] = limit

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
        if self.planar:
            self.cap[ids] = force  # `command` turns it into the slides' limits
        else:
            limit[rows, self.ctrl_idx[:, :2]] = np.stack([-force, force], -1)[:, :, None, :]  # both slides

    def place(self, qpos: np.ndarray, qvel: np.ndarray, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> None:
        """Put the robots of envs `ids` at `xy` (n, A, 2) with headings `yaw` (n, A), at rest."""
        qpos[np.ix_(ids, self.qpos_idx[:, 0])] = xy[..., 0]
        qpos[np.ix_(ids, self.qpos_idx[:, 1])] = xy[..., 1]
        qpos[np.ix_(ids, self.qpos_idx[:, 2])] = yaw
        qvel[np.ix_(ids, self.qvel_idx.reshape(-1))] = 0.0
        if self.fall is not None:
            self.load[ids], self.shove[ids], self.hazard[ids], self.fallen[ids] = 0.0, 0.0, 0.0, False
            if self.held_channel:
                self.held[ids] = 0.0
            self.threshold[ids] = self.rng.exponential(1.0, size=(len(ids), self.threshold.shape[1]))
