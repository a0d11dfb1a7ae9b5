"""What disturbs the Go1 of the locomotion env (`level=locomotion`), beside its commands: event terms, named in config.

`level.events` lists them as `{name: {func: module:Class, params}}`, as rewards, observations and exceptions are
listed; a null entry drops one. In evaluation, `level.eval_events.<name>` replaces some of an event's params (by
default: no pushes, no held force, no load, no teammates: tracking measured on flat ground, undisturbed).

An event is a class (`Event`); the env builds each with its params and calls its hooks in config order, so the
order of the random draws is the order of the list: `add_to_scene` before the model compiles (given the params
of both modes, training and evaluation: a scene holds what either uses), `startup` once after the env's own per-env
draws, `reset` at each episode start, `before_physics` and `after_physics` around every policy step. Every hook
does nothing unless the event overrides it.

The shipped events: a random push every `interval_s` (`Push`), a held force leaning on the trunk (`Lean`), a free
load ahead of the robot along its first command (`Load`), teammates beside it that lean into it (`Teammates`).
The scene parts they add are built in `mapush/lowlevel/go1_training_scene.py`.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mapush.config_terms import bind_term, check_replaced_events
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import Go1, rotate_into_world
from mapush.lowlevel.go1_training_scene import (
    LOAD_BODIES,
    LOAD_GEOM_FRICTION,
    MATE_PARKED_XY,
    MATE_PREFIX,
    PARKED_XY,
    add_loads,
    add_teammates,
    locomotion_spec,
)
from mapush.planning.geometry import rotate


class Event:
    """One disturbance of the locomotion env (see the module docstring); `env` is the `LocomotionEnv`."""

    is_event_term = True  # config_terms lists classes marked so among a module's valid terms

    def __init__(self, env) -> None:
        self.env = env

    @classmethod
    def add_to_scene(cls, spec: mujoco.MjSpec, robot: dict, modes: tuple[dict, dict]) -> None:
        """Add the bodies the event needs to the scene (`robot`: the lowlevel config; `modes`: the params of this
        mode, then of the other)."""

    def startup(self) -> None:
        """Draw what stays fixed for each env (after the env's friction and mass)."""

    def reset(self, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray, commands: np.ndarray) -> None:
        """Set up the new episodes of envs `ids`: the robot's start position (n, 2), heading (n,), commands (n, 3)."""

    def before_physics(self) -> None:
        """Act before the physics steps (the robot's joint targets are set)."""

    def after_physics(self) -> None:
        """Act after the physics stepped (the episode step counted), before the env reads its state."""


class Push(Event):
    """Every `interval_s`, a random change of each trunk's horizontal velocity of up to `velocity_mps` per axis."""

    def __init__(self, env, interval_s: float, velocity_mps: float) -> None:
        super().__init__(env)
        self.interval_s, self.velocity = interval_s, velocity_mps

    def after_physics(self) -> None:
        env = self.env
        due = env.every(self.interval_s).numpy()
        if self.velocity > 0 and due.any():
            ids = np.flatnonzero(due)
            env.sim.qvel[ids, 0:2] += env.rng.uniform(-1, 1, size=(len(ids), 2)) * self.velocity


class Lean(Event):
    """Every `interval_s`, a horizontal force on each trunk of size U(0, `force_n`) N in a random direction, held
    `duration_s`: the sustained load of pushing an object or being leaned on, which `Push` does not give (0 N:
    none)."""

    def __init__(self, env, force_n: float, duration_s: float, interval_s: float) -> None:
        super().__init__(env)
        self.force_n, self.duration_s, self.interval_s = force_n, duration_s, interval_s
        self.steps_left = np.zeros(env.num_envs, dtype=np.int64)

    def reset(self, ids, xy, yaw, commands) -> None:
        self.steps_left[ids] = 0

    def after_physics(self) -> None:
        env = self.env
        if self.force_n <= 0:
            return
        self.steps_left -= 1
        env.applied[self.steps_left == 0, env.trunk, :2] = 0.0
        due = env.every(self.interval_s).numpy()
        if due.any():
            ids = np.flatnonzero(due)
            size = env.rng.uniform(0.0, self.force_n, size=len(ids))
            heading = env.rng.uniform(-math.pi, math.pi, size=len(ids))
            env.applied[ids, env.trunk, 0] = size * np.cos(heading)
            env.applied[ids, env.trunk, 1] = size * np.sin(heading)
            self.steps_left[ids] = max(1, round(self.duration_s / env.dt))


class Load(Event):
    """A `fraction` of the episodes get one free load, the pushing tasks' box (`box_size_m`) or cylinder
    (`cylinder_size_m`: radius, height), at a random yaw, U(`distance_m`) ahead of the trunk (to the cylinder's
    side, or the circle round the box's corners) along the commanded velocity (any way for a command to stand or
    turn), for the robot to walk into unseen. Each env's load drags U(`resistance_n`) N on its floor (the mass
    follows from the env's friction). The other load, and both in the other episodes, wait parked."""

    def __init__(
        self,
        env,
        fraction: float,
        box_size_m: list,
        cylinder_size_m: list,
        resistance_n: list,
        distance_m: list,
    ) -> None:
        super().__init__(env)
        self.fraction, self.resistance_n, self.distance_m = fraction, resistance_n, distance_m
        names = LOAD_BODIES.values() if _has_body(env.model, LOAD_BODIES["box"]) else ()
        self.bodies = [env.model.body(name) for name in names]
        self.reach = {"box": math.hypot(*box_size_m[:2]) / 2, "cylinder": cylinder_size_m[0]}

    @classmethod
    def add_to_scene(cls, spec, robot, modes) -> None:
        if any(params["fraction"] > 0 for params in modes):
            add_loads(spec, modes[0]["box_size_m"], modes[0]["cylinder_size_m"])

    def startup(self) -> None:
        """Each load's mass in each env: the one whose drag on that env's floor is U(resistance_n) newtons."""
        env = self.env
        if not self.bodies:
            return
        batch = env.sim.batch
        mass, inertia = batch.expand("body_mass"), batch.expand("body_inertia")
        for body in self.bodies:
            resistance = env.rng.uniform(*self.resistance_n, size=env.num_envs)
            floor_mu = np.maximum(env.floor_friction, LOAD_GEOM_FRICTION)
            mass[:, body.id] = resistance / (floor_mu * -env.model.opt.gravity[2])
            inertia[:, body.id] = np.outer(mass[:, body.id] / body.mass[0], body.inertia)  # a uniform solid's

    def reset(self, ids, xy, yaw, commands) -> None:
        env, n = self.env, len(ids)
        if not self.bodies:
            return
        heading = yaw + np.arctan2(commands[:, 1], commands[:, 0])
        still = np.linalg.norm(commands[:, :2], axis=1) < 0.1
        heading[still] = env.rng.uniform(-math.pi, math.pi, size=int(still.sum()))
        used = np.where(env.rng.random(n) < self.fraction, env.rng.integers(len(self.bodies), size=n), -1)
        gap = env.rng.uniform(*self.distance_m, size=n)
        spin = env.rng.uniform(-math.pi, math.pi, size=n)
        for k, (shape, body) in enumerate(zip(LOAD_BODIES, self.bodies, strict=True)):
            address = env.model.jnt_qposadr[body.jntadr[0]]
            here = used == k
            centre = go1.TRUNK_SIZE[0] / 2 + gap + self.reach[shape]  # a box's corner at most `gap` away
            ahead = centre[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)
            placed = np.where(here[:, None], ahead, PARKED_XY[shape])
            pose = np.zeros((n, 7))
            pose[:, :2], pose[:, 2] = placed, env.model.body_pos[body.id][2]
            pose[:, 3], pose[:, 6] = np.cos(spin / 2), np.sin(spin / 2)
            env.sim.qpos[ids, address : address + 7] = pose


class Teammates(Event):
    """`count` Go1s beside the robot, shoulder to shoulder as in a pushing team, walked by the frozen locomotion
    policy (`lowlevel.policy`). A `fraction` of the episodes start with every teammate beside the robot,
    alternately on its left and right (the third and fourth one robot-length and `row_gap_m` further back),
    U(`gap_m`) from its side, U(`along_m`) ahead or behind, headed as it within `heading_rad`; they walk at the
    robot's commanded velocity plus their episode's lean toward it (U(`lean_mps`) m/s). In the other episodes they
    stand parked. A scene has them only where some episodes use them."""

    def __init__(
        self,
        env,
        fraction: float,
        count: int,
        gap_m: list,
        lean_mps: list,
        along_m: list,
        heading_rad: float,
        row_gap_m: float,
    ) -> None:
        super().__init__(env)
        self.fraction, self.gap_m, self.lean_mps, self.along_m = fraction, gap_m, lean_mps, along_m
        self.heading_rad, self.row_gap_m = heading_rad, row_gap_m
        k = count if _has_body(env.model, MATE_PREFIX.format(0) + go1.ROOT_BODY) else 0
        self.mates = Go1(env.cfg["lowlevel"]) if k else None  # their go1 backend; None: not in the scene
        if self.mates:
            self.mates.bind(env.model, [MATE_PREFIX.format(i) for i in range(k)])
        self.parked = np.array([[MATE_PARKED_XY[0] + i, MATE_PARKED_XY[1]] for i in range(k)])
        self.used = np.zeros(env.num_envs, dtype=bool)  # (E,) whose episodes have them
        self.lean = np.zeros(env.num_envs)  # (E,) m/s toward the robot

    @classmethod
    def add_to_scene(cls, spec, robot, modes) -> None:
        if any(params["fraction"] > 0 for params in modes):
            add_teammates(spec, robot, modes[0]["count"])

    def reset(self, ids, xy, yaw, commands) -> None:
        env, n, k = self.env, len(ids), len(self.parked)
        if not self.mates:
            return
        used = env.rng.random(n) < self.fraction
        self.used[ids] = used
        self.lean[ids] = np.where(used, env.rng.uniform(*self.lean_mps, size=n), 0.0)
        length, width = env.robot["size"][:2]
        side = np.where(np.arange(k) % 2 == 0, 1.0, -1.0)  # (k,) left, right, ...
        lateral = side * (width + env.rng.uniform(*self.gap_m, size=(n, k)))
        along = -(length + self.row_gap_m) * (np.arange(k) // 2) + env.rng.uniform(*self.along_m, size=(n, k))
        cos, sin = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        offset = np.stack([cos * along - sin * lateral, sin * along + cos * lateral], -1)  # (n, k, 2)
        placed = np.where(used[:, None, None], xy[:, None, :] + offset, self.parked[None])
        turn = env.rng.uniform(-self.heading_rad, self.heading_rad, size=(n, k))
        heading = np.where(used[:, None], yaw[:, None] + turn, 0.0)
        self.mates.place(env.sim.qpos, env.sim.qvel, ids, placed, heading)

    def before_physics(self) -> None:
        """Every teammate in use walks at the robot's commanded velocity (world frame, from the robot's heading
        now) plus its env's lean toward the robot; parked ones stand. Their policy writes their joint targets."""
        env = self.env
        if not self.mates:
            return
        qpos, qvel = env.sim.qpos, env.sim.qvel
        command = np.concatenate([env.commands[:, :2].numpy(), np.zeros((env.num_envs, 1))], -1)
        walk = rotate_into_world(env.robot_qpos[:, 3:7], command)[:, None, :2]  # (E, 1, 2)
        mates = self.mates.read(qpos, qvel)
        toward = env.robot_qpos[:, None, :2] - mates["xy"]
        toward /= np.maximum(np.linalg.norm(toward, axis=-1, keepdims=True), 1e-6)
        velocity = (walk + self.lean[:, None, None] * toward) * self.used[:, None, None]  # (E, k, 2) world
        body = rotate(velocity, mates["yaw"], inverse=True)  # into each teammate's frame
        self.mates.command(env.sim.ctrl, qpos, qvel, np.concatenate([body, np.zeros_like(body[..., :1])], -1))


def _has_body(model: mujoco.MjModel, name: str) -> bool:
    """Whether the scene holds a body of that name (whether `add_to_scene` added it)."""
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0


def event_specs(level: dict, evaluation: bool) -> dict[str, tuple[type, dict, dict]]:
    """`{name: (class, its params in this mode, in the other)}` of a level config's events, in order, each checked
    against its class (BadInput for a bad path, param or `eval_events` entry)."""
    events, overrides = level.get("events") or {}, level.get("eval_events") or {}
    check_replaced_events("level.eval_events", events, overrides)
    specs = {}
    for name, spec in events.items():
        if spec is None:
            continue
        training = bind_term("level.events", name, spec)
        replaced = {**training.params, **(overrides.get(name) or {})}
        judging = bind_term("level.eval_events", name, {**spec, "params": replaced})
        modes = (judging.params, training.params) if evaluation else (training.params, judging.params)
        specs[name] = (training.func, *modes)
    return specs


def locomotion_model(cfg: dict, evaluation: bool = False, specs: dict | None = None) -> mujoco.MjModel:
    """The locomotion env's model: one Go1 (`locomotion_spec`) and what its events add (`specs`: `event_specs` of
    the config in this mode, where the caller has them)."""
    spec = locomotion_spec(cfg["lowlevel"], cfg["sim"]["timestep"])
    for event, *modes in (specs or event_specs(cfg["level"], evaluation)).values():
        event.add_to_scene(spec, cfg["lowlevel"], tuple(modes))
    return spec.compile()
