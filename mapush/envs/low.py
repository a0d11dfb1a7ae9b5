"""The low level: a Go1 learns to track (vx, vy, yaw rate) commands on flat ground (paper III-B; docs/design.md).

E single-robot MuJoCo sims stepped together by `mujoco.batch`; no Python loop over envs. The policy acts at 50 Hz:
its 12 actions are joint-angle offsets from the standing pose (times `lowlevel.action_scale`), which the model's PD
servos track at 200 Hz (every 5 ms physics step), capped at the Go1's motor torques (`go1_constants`).

Observation: the robot's own senses (`go1.proprioception`, 45 numbers, shared with the go1 backend that later runs
the policy under the pushing levels). The critic also gets the body-frame linear velocity (3), which the robot
cannot measure. Servo gains and the action scale are the go1 backend's (`conf/lowlevel/go1.yaml`).

Commands are drawn per env from `level.commands` at reset and every `resample_s`; a `zero_fraction` of them are
"stand still" and a `turn_fraction` "turn on the spot". Evaluation draws them from `level.eval_commands`, the range
the mid level commands, and pushes with `level.eval_push_velocity` (0 by default: the tracking target is on flat
ground, undisturbed).

Domain randomization: ground and foot friction and an added trunk mass, drawn once per env, a random push (a
change of the trunk's horizontal velocity) every `push_interval_s`, and optionally a held horizontal force on the
trunk (`force_n`: the load of pushing an object or being leaned on). Optionally (`randomize.load`) a free box or
cylinder of the pushing tasks' size stands ahead of the robot, along its first command, for it to walk into and
shove unseen, as it must under the pushing levels (`eval_load_fraction` measures a policy doing so). Optionally
(`randomize.teammates`) teammates stand beside it, shoulder to shoulder as a pushing team's robots do: Go1s walked
by the frozen locomotion policy (`lowlevel.policy`), which walk along at the robot's commanded velocity and lean
into it (`eval_teammate_fraction` measures a policy among them). A fall
(trunk too low, tilted too far, or touching the ground) ends the episode as an exception; reaching the timeout is a
success.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import torch

from mapush.envs.core import EnvCore
from mapush.errors import BadInput
from mapush.lowlevel import backend_name
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import Go1, proprioception, rotate_into_body, rotate_into_world
from mapush.lowlevel.go1_model import go1_spec, standalone_spec
from mapush.planning.geometry import rotate
from mapush.sim.core import BatchSim
from mapush.sim.geoms import drawn_geom_ids, quat_multiply

TRACKING_ERRORS = ("velocity_error", "yaw_rate_error")
"""The tracking errors (methods of `LocomotionEnv`) averaged over each episode and reported by its evaluation."""


LOAD_BODIES = {"box": "load_box", "cylinder": "load_cylinder"}
"""The free bodies a run with `randomize.load` adds, by shape; each episode with a load uses one, the other waits
at its `PARKED_XY`."""
ROBOT_NQ, ROBOT_NV = 7 + len(go1.JOINT_NAMES), 6 + len(go1.JOINT_NAMES)
"""The Go1's columns of qpos and qvel (its free joint, then its joints), which come first: any load follows."""
PARKED_XY = {"box": (100.0, 100.0), "cylinder": (100.0, -100.0)}
"""m; where each load waits when not in use, beyond any robot's reach in an episode and apart from the other."""
MATE_PREFIX = "mate{}/"
"""The name prefix of teammate k, a Go1 attached to the scene after the robot and any loads."""
MATE_PARKED_XY = (-100.0, 100.0)
"""m; where teammate k stands when not in use (k m further along x), beyond reach and apart from the loads."""
LOAD_GEOM_FRICTION = 0.1
"""A load's own sliding friction, below the floor's and the Go1's: MuJoCo takes the larger of a contact's two, so
the floor sets the load's drag (`resistance_n` picks its mass) and the robot's 1.0 its grip, as in a pushing scene."""


def locomotion_model(cfg: dict) -> mujoco.MjModel:
    """One Go1 on flat ground with the go1 backend's servo gains and the sim's timestep, and the loads and the
    teammates where a run asks for them (`load_fractions`, `teammate_fractions`). The Go1's 12 actuators come
    first."""
    robot = cfg["lowlevel"]
    spec = standalone_spec(robot["kp"], robot["kd"], cfg["sim"]["timestep"], robot.get("torque_limits"))
    load = cfg["level"]["randomize"].get("load")  # runs made before the key have none
    if any(load_fractions(cfg)):
        box, cylinder = load["box_size_m"], load["cylinder_size_m"]
        shapes = {
            "box": (mujoco.mjtGeom.mjGEOM_BOX, [box[0] / 2, box[1] / 2, box[2] / 2], box[2] / 2),
            "cylinder": (mujoco.mjtGeom.mjGEOM_CYLINDER, [cylinder[0], cylinder[1] / 2, 0.0], cylinder[1] / 2),
        }
        for shape, (kind, size, half_height) in shapes.items():
            body = spec.worldbody.add_body(name=LOAD_BODIES[shape], pos=[*PARKED_XY[shape], half_height])
            body.add_freejoint()
            body.add_geom(type=kind, size=size, mass=1.0, friction=[LOAD_GEOM_FRICTION, 0.005, 0.0001])
    for k in range(teammate_count(cfg)):
        mate = go1_spec(robot["kp"], robot["kd"], robot.get("torque_limits"), foot_friction=robot["foot_friction"])
        spec.attach(mate, frame=spec.worldbody.add_frame(), prefix=MATE_PREFIX.format(k))
    return spec.compile()


def load_fractions(cfg: dict) -> tuple[float, float]:
    """The share of training and of evaluation episodes that start with a load ahead (0, 0 without the key)."""
    load = cfg["level"]["randomize"].get("load") or {}
    return float(load.get("fraction", 0.0)), float(cfg["level"].get("eval_load_fraction", 0.0))


def teammate_fractions(cfg: dict) -> tuple[float, float]:
    """The share of training and of evaluation episodes with teammates beside the robot (0, 0 without the key)."""
    mates = cfg["level"]["randomize"].get("teammates") or {}
    return float(mates.get("fraction", 0.0)), float(cfg["level"].get("eval_teammate_fraction", 0.0))


def teammate_count(cfg: dict) -> int:
    """How many teammate Go1s the scene holds: `randomize.teammates.count` where any episode uses them, else 0."""
    return int(cfg["level"]["randomize"]["teammates"]["count"]) if any(teammate_fractions(cfg)) else 0


@dataclass
class LocomotionState:
    """What every Go1 senses and does now, float32 tensors over envs E (body frame unless said otherwise)."""

    base_height: torch.Tensor  # (E,) trunk origin above the ground, m
    lin_vel: torch.Tensor  # (E, 3) m/s
    ang_vel: torch.Tensor  # (E, 3) rad/s
    gravity: torch.Tensor  # (E, 3) unit vector of gravity
    torques: torch.Tensor  # (E, 12) joint torques, N m
    feet_xyz: torch.Tensor  # (E, 4, 3) foot centres, world frame, m
    feet_speed: torch.Tensor  # (E, 4) planar foot speed since the last step, m/s
    foot_contact: torch.Tensor  # (E, 4) bool
    trunk_z: torch.Tensor  # (E,) trunk box centre height, m


class LocomotionEnv(EnvCore):
    """E Go1s on flat ground, each tracking its own velocity command; see the module docstring."""

    state: LocomotionState

    def __init__(self, cfg: dict, num_envs: int | None = None, evaluation: bool = False):
        self.validate(cfg)
        level, sim_cfg = cfg["level"], cfg["sim"]
        E = num_envs or cfg["num_envs"]
        self.model = locomotion_model(cfg)
        sim = BatchSim(self.model, E, sim_cfg["decimation"], sim_cfg["nthread"])
        super().__init__(cfg, sim, E, num_agents=1, rows=1, dt=sim.dt)
        self.command_ranges = level["eval_commands" if evaluation else "commands"]
        self.push_velocity = level["eval_push_velocity"] if evaluation else level["randomize"]["push_velocity"]
        self.force_n = level["eval_force_n"] if evaluation else level["randomize"]["force_n"]
        self.load_fraction = load_fractions(cfg)[1 if evaluation else 0]
        self.num_actions = 12
        self.robot = cfg["lowlevel"]  # servo gains and action scale: the go1 backend's, which runs the policy later
        self.action_limit = float(self.robot["action_clip"])
        b = sim.batch
        self.geom_xpos = b.bind("geom_xpos")
        self.actuator_force = b.bind("actuator_force")[:, :12]  # the Go1's; any teammates' follow
        self.body_xquat = b.bind("xquat")
        self.applied = b.bind("xfrc_applied")  # (E, nbody, 6) force and torque on each body, world frame
        self.trunk = self.model.body(go1.ROOT_BODY).id
        self.force_steps_left = np.zeros(E, dtype=np.int64)
        self.feet = np.array([self.model.geom(name).id for name in go1.FOOT_NAMES])
        self.trunk_geom = self.model.geom("trunk_box").id
        self.trunk_half_height = go1.TRUNK_SIZE[2] / 2
        self.default_pose = np.array(go1.default_joint_angles())
        self.robot_qpos, self.robot_qvel = sim.qpos[:, :ROBOT_NQ], sim.qvel[:, :ROBOT_NV]  # views
        self.loads = [self.model.body(name) for name in LOAD_BODIES.values()] if any(load_fractions(cfg)) else []
        self.teammate_fraction = teammate_fractions(cfg)[1 if evaluation else 0]
        self._bind_teammates()
        self.rng = np.random.default_rng(int(cfg["seed"]))
        self._randomize_once()
        self.commands = torch.zeros(E, 3)
        self.actions = torch.zeros(E, 12)
        self.last_actions = torch.zeros(E, 12)
        self.air_time = torch.zeros(E, 4)
        self.first_contact = torch.zeros(E, 4, dtype=torch.bool)
        self.tracking_error_sums = {name: torch.zeros(E) for name in TRACKING_ERRORS}
        self.state = None  # read at the first reset; the foot speeds need the previous foot positions
        self.drawn_geoms = np.array(drawn_geom_ids(self.model))
        self.reset(np.arange(E))

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

    def seed(self, seed: int) -> None:
        """Reseed the start draws: commands (torch) and poses, headings and pushes (numpy)."""
        super().seed(seed)
        self.rng = np.random.default_rng(int(seed))

    def _randomize_once(self) -> None:
        """Per-env ground and foot friction and added trunk mass (drawn once, as the original drew friction)."""
        rand = self.cfg["level"]["randomize"]
        E, batch = self.num_envs, self.sim.batch
        friction = batch.expand("geom_friction")
        mu = self.rng.uniform(*rand["friction"], size=E)
        floor = self.model.geom("floor").id
        friction[:, floor, 0] = mu
        friction[:, self.feet, 0] = mu[:, None]
        mass = batch.expand("body_mass")
        trunk = self.model.body(go1.ROOT_BODY).id
        mass[:, trunk] = self.model.body_mass[trunk] + self.rng.uniform(*rand["added_mass"], size=E)
        inertia = batch.expand("body_inertia") if self.loads else None
        for body in self.loads:  # the mass whose drag on this env's floor is U(resistance_n) newtons
            resistance = self.rng.uniform(*rand["load"]["resistance_n"], size=E)
            mass[:, body.id] = resistance / (np.maximum(mu, LOAD_GEOM_FRICTION) * -self.model.opt.gravity[2])
            inertia[:, body.id] = np.outer(mass[:, body.id] / body.mass[0], body.inertia)  # a uniform solid's
        batch.set_const()

    # ----------------------------------------------------------------------------------------------------------
    def _start_episodes(self, ids: np.ndarray, t: torch.Tensor) -> None:
        """Standing pose (joint angles jittered), random heading, new commands."""
        n, sim = len(ids), self.sim
        sim.restart(ids)
        qpos = np.zeros((n, ROBOT_NQ))
        qpos[:, 2] = go1.standing_height() + 0.02
        yaw = self.rng.uniform(-math.pi, math.pi, size=n)
        qpos[:, 3], qpos[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)
        qpos[:, 7:] = self.default_pose * self.rng.uniform(*self.cfg["level"]["randomize"]["joint_scale"], size=(n, 12))
        sim.qpos[ids, :ROBOT_NQ] = qpos
        sim.qvel[ids] = 0.0
        sim.ctrl[ids] = 0.0
        sim.ctrl[ids, :12] = self.default_pose
        self.applied[ids, self.trunk] = 0.0
        self.force_steps_left[ids] = 0
        self.commands[t] = self._sample_commands(n)
        if self.loads:
            self._place_loads(ids, yaw, self.commands[t].numpy())
        if self.mates:
            self._place_teammates(ids, qpos[:, :2], yaw)
        sim.forward(ids)
        self.actions[t] = 0.0
        self.last_actions[t] = 0.0
        self.air_time[t] = 0.0
        for sums in self.tracking_error_sums.values():
            sums[t] = 0.0

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

    def _sample_commands(self, n: int) -> torch.Tensor:
        spec = self.command_ranges
        low = torch.tensor([spec["vx"][0], spec["vy"][0], spec["yaw_rate"][0]])
        high = torch.tensor([spec["vx"][1], spec["vy"][1], spec["yaw_rate"][1]])
        commands = low + (high - low) * torch.rand(n, 3, generator=self.generator)
        still = torch.rand(n, generator=self.generator) < spec["zero_fraction"]
        commands = torch.where(still.unsqueeze(-1), torch.zeros_like(commands), commands)
        if spec.get("turn_fraction", 0.0) > 0:  # runs made before the key have none (and draw nothing more)
            turning = torch.rand(n, generator=self.generator) < spec["turn_fraction"]
            commands[turning, :2] = 0.0
        return commands

    def _read_state(self) -> None:
        """Body-frame velocities, gravity direction, torques, foot contacts and speeds (`LocomotionState`)."""
        qpos, qvel = self.robot_qpos, self.robot_qvel
        quat = qpos[:, 3:7]
        down = np.broadcast_to(np.array([0.0, 0.0, -1.0]), (self.num_envs, 3))
        feet = torch.from_numpy(self.geom_xpos[:, self.feet].astype(np.float32))  # (E, 4, 3)
        previous = feet if self.state is None else self.state.feet_xyz

        def tensor(array: np.ndarray) -> torch.Tensor:
            return torch.from_numpy(array.astype(np.float32))

        self.state = LocomotionState(
            base_height=tensor(qpos[:, 2]),
            lin_vel=tensor(rotate_into_body(quat, qvel[:, 0:3])),
            ang_vel=tensor(qvel[:, 3:6]),  # a free joint's is body-frame
            gravity=tensor(rotate_into_body(quat, down)),
            torques=tensor(self.actuator_force),
            feet_xyz=feet,
            feet_speed=torch.linalg.vector_norm(feet[..., :2] - previous[..., :2], dim=-1) / self.dt,
            foot_contact=feet[..., 2] < go1.FOOT_RADIUS + self.cfg["level"]["contact_margin_m"],
            trunk_z=tensor(self.geom_xpos[:, self.trunk_geom, 2]),
        )

    # ----------------------------------------------------------------------------------------------------------
    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """One 20 ms policy step. actions: (E, 1, 12). Returns obs, rewards (E, 1), terminated, truncated, info."""
        self.last_actions = self.actions
        self.actions = actions.reshape(self.num_envs, 12).clamp(-self.action_limit, self.action_limit)
        self.sim.ctrl[:, :12] = self.default_pose + self.robot["action_scale"] * self.actions.numpy().astype(np.float64)
        if self.mates:
            self._drive_teammates()
        failed = self.sim.advance()
        self.episode_step += 1
        self._push()
        self._lean()
        self._read_state()
        self._update_air_time()
        self.diverged = torch.zeros(self.num_envs, dtype=torch.bool)
        self.diverged[torch.from_numpy(failed)] = True
        self.diverged |= ~torch.isfinite(self.state.base_height)
        flags = self.exception_flags()
        self.exception = flags.any(0)
        self.exception_kind = self.first_exception(flags)
        truncated = (self.episode_step >= self.max_episode_length) & ~self.exception
        self.success = truncated  # a whole episode without a fall
        reward, parts = self.rewards.compute(self)
        for name, sums in self.tracking_error_sums.items():
            sums += getattr(self, name)()
        return self._finish_step(reward, parts, self.exception, truncated, self.commands.unsqueeze(1))

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets): the Go1's geom poses, its trunk, and its commanded
        and actual planar velocity in the world frame (`Go1Layout.scene`)."""
        qpos, qvel = self.robot_qpos, self.robot_qvel
        quat = qpos[:, 3:7]
        bodies = self.model.geom_bodyid[self.drawn_geoms]
        command = np.concatenate([self.commands[:, :2].numpy(), np.zeros((self.num_envs, 1))], -1)
        frame = {
            "geom_xpos": self.geom_xpos[:, self.drawn_geoms],
            "geom_xquat": quat_multiply(self.body_xquat[:, bodies], self.model.geom_quat[self.drawn_geoms]),
            "trunk_xyz": qpos[:, 0:3],
            "trunk_quat": quat,
            "command_xy": rotate_into_world(quat, command)[:, :2],
            "velocity_xy": qvel[:, 0:2],
        }
        return {name: torch.from_numpy(np.ascontiguousarray(value)) for name, value in frame.items()}

    def velocity_error(self) -> torch.Tensor:
        """|commanded - actual| planar velocity, m/s (E,)."""
        return torch.linalg.vector_norm(self.commands[:, :2] - self.state.lin_vel[:, :2], dim=-1)

    def yaw_rate_error(self) -> torch.Tensor:
        """|commanded - actual| yaw rate, rad/s (E,)."""
        return (self.commands[:, 2] - self.state.ang_vel[:, 2]).abs()

    def _update_air_time(self) -> None:
        """Seconds each foot has been off the ground; `first_contact` marks feet that land this step."""
        self.air_time += self.dt
        self.first_contact = (self.air_time > self.dt) & self.state.foot_contact
        self.landed_air_time = self.air_time * self.first_contact
        self.air_time = self.air_time * ~self.state.foot_contact

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

    def _before_reset(self, done: torch.Tensor) -> None:
        """New commands every `resample_s`, after the step's were recorded."""
        due = self._every(self.command_ranges["resample_s"]) & (self.episode_step > 0)
        if due.any():
            self.commands[due] = self._sample_commands(int(due.sum()))

    def _episode_info(self, done: torch.Tensor) -> dict:
        steps = self.episode_step.clamp(min=1).float()
        errors = {name: sums / steps for name, sums in self.tracking_error_sums.items()}
        return self.outcomes.info({**self.episode_end(done, self.exception), **errors}, self.episode_sums, errors)

    @classmethod
    def validate(cls, cfg: dict) -> None:
        """Check the robot and the terms before anything is built."""
        if backend_name(cfg["lowlevel"]) != "go1":
            raise BadInput(f"level=low trains the Go1, not lowlevel={cfg['lowlevel']['name']}; valid: lowlevel=go1")
        cls.check_terms(cfg)


def proprioceptive_observation(env) -> torch.Tensor:
    """The Go1's own senses (`go1.proprioception`, 45 numbers), as the go1 backend computes them: (E, 45)."""
    sensed = proprioception(
        env.robot_qpos, env.robot_qvel, env.commands.numpy(), env.actions.numpy(), env.default_pose
    ).astype(np.float32)
    return torch.from_numpy(sensed)


def body_linear_velocity(env) -> torch.Tensor:
    """The trunk's body-frame linear velocity (3), which the robot cannot measure (critic only): (E, 3)."""
    return env.state.lin_vel
