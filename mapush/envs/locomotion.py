"""The low level: a Go1 learns to track (vx, vy, yaw rate) commands on flat ground (paper III-B; docs/design.md).

E single-robot MuJoCo sims stepped together by `mujoco.batch`; no Python loop over envs. The policy acts at 50 Hz:
its 12 actions are joint-angle offsets from the standing pose (times `lowlevel.action_scale`), which the model's PD
servos track at 200 Hz (every 5 ms physics step), capped at the Go1's motor torques (`go1_constants`).

Observation: the robot's own senses (`go1.proprioception`, 45 numbers, shared with the go1 backend that later runs
the policy under the pushing levels). The critic also gets the body-frame linear velocity (3), which the robot
cannot measure. Servo gains and the action scale are the go1 backend's (`conf/lowlevel/go1.yaml`).

Commands are drawn per env from `level.commands` at reset and every `resample_s`; a `zero_fraction` of them are
"stand still" and a `turn_fraction` "turn on the spot". Evaluation draws them from `level.eval_commands`, the range
the mid level commands.

Domain randomization: ground and foot friction and an added trunk mass, drawn once per env (`level.randomize`).
Disturbances are event terms (`level.events`, `locomotion_events.py`): a random push (a change of the trunk's horizontal
velocity) every few seconds, and optionally a held horizontal force on the trunk (the load of pushing an object or
being leaned on), a free box or cylinder of the pushing tasks' size ahead of the robot for it to walk into and
shove unseen, and teammates beside it, shoulder to shoulder as a pushing team's robots are. Evaluation replaces
their params with `level.eval_events` (by default it measures tracking undisturbed). A fall (trunk too low,
tilted too far, or touching the ground) ends the episode as an exception; reaching the timeout is a success.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from mapush.envs.base import EnvCore
from mapush.envs.locomotion_events import event_specs, locomotion_model
from mapush.errors import BadInput
from mapush.lowlevel import backend_name
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import proprioception, rotate_into_body, rotate_into_world
from mapush.lowlevel.go1_training_scene import ROBOT_NQ, ROBOT_NV
from mapush.sim.batch import BatchSim
from mapush.sim.geoms import drawn_geom_ids, quat_multiply

TRACKING_ERRORS = ("velocity_error", "yaw_rate_error")
"""The tracking errors (methods of `LocomotionEnv`) averaged over each episode and reported by its evaluation."""


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
    """E Go1s on flat ground, each tracking its own velocity command; see the module docstring. `events` holds its
    event terms by name (`locomotion_events.Event`)."""

    state: LocomotionState

    def __init__(self, cfg: dict, num_envs: int | None = None, evaluation: bool = False):
        self.validate(cfg)
        level, sim_cfg = cfg["level"], cfg["sim"]
        E = num_envs or cfg["num_envs"]
        specs = event_specs(level, evaluation)
        self.model = locomotion_model(cfg, evaluation, specs)
        sim = BatchSim(self.model, E, sim_cfg["decimation"], sim_cfg["nthread"])
        super().__init__(cfg, sim, E, num_agents=1, rows=1, dt=sim.dt)
        self.command_ranges = level["eval_commands" if evaluation else "commands"]
        self.num_actions = 12
        self.robot = cfg["lowlevel"]  # servo gains and action scale: the go1 backend's, which runs the policy later
        self.action_limit = float(self.robot["action_clip"])
        b = sim.batch
        self.geom_xpos = b.bind("geom_xpos")
        self.actuator_force = b.bind("actuator_force")[:, :12]  # the Go1's; any teammates' follow
        self.body_xquat = b.bind("xquat")
        self.applied = b.bind("xfrc_applied")  # (E, nbody, 6) force and torque on each body, world frame
        self.trunk = self.model.body(go1.ROOT_BODY).id
        self.feet = np.array([self.model.geom(name).id for name in go1.FOOT_NAMES])
        self.trunk_geom = self.model.geom("trunk_box").id
        self.trunk_half_height = go1.TRUNK_SIZE[2] / 2
        self.default_pose = np.array(go1.default_joint_angles())
        self.robot_qpos, self.robot_qvel = sim.qpos[:, :ROBOT_NQ], sim.qvel[:, :ROBOT_NV]  # views
        self.events = {name: event(self, **params) for name, (event, params, _) in specs.items()}
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

    def seed(self, seed: int) -> None:
        """Reseed the start draws: commands (torch) and poses, headings and pushes (numpy)."""
        super().seed(seed)
        self.rng = np.random.default_rng(int(seed))

    def _randomize_once(self) -> None:
        """Per-env ground and foot friction and added trunk mass (drawn once, as the original drew friction), then
        what each event draws once."""
        rand = self.cfg["level"]["randomize"]
        E, batch = self.num_envs, self.sim.batch
        friction = batch.expand("geom_friction")
        self.floor_friction = self.rng.uniform(*rand["friction"], size=E)  # (E,)
        floor = self.model.geom("floor").id
        friction[:, floor, 0] = self.floor_friction
        friction[:, self.feet, 0] = self.floor_friction[:, None]
        mass = batch.expand("body_mass")
        mass[:, self.trunk] = self.model.body_mass[self.trunk] + self.rng.uniform(*rand["added_mass"], size=E)
        for event in self.events.values():
            event.startup()
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
        self.commands[t] = self._sample_commands(n)
        for event in self.events.values():
            event.reset(ids, qpos[:, :2], yaw, self.commands[t].numpy())
        sim.forward(ids)
        self.actions[t] = 0.0
        self.last_actions[t] = 0.0
        self.air_time[t] = 0.0
        for sums in self.tracking_error_sums.values():
            sums[t] = 0.0

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
        for event in self.events.values():
            event.before_physics()
        failed = self.sim.advance()
        self.episode_step += 1
        for event in self.events.values():
            event.after_physics()
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

    def every(self, seconds: float) -> torch.Tensor:
        """(E,) envs whose episode is at a multiple of `seconds` (at least one step) this step."""
        return self.episode_step % max(1, round(seconds / self.dt)) == 0

    def _before_reset(self, done: torch.Tensor) -> None:
        """New commands every `resample_s`, after the step's were recorded."""
        due = self.every(self.command_ranges["resample_s"]) & (self.episode_step > 0)
        if due.any():
            self.commands[due] = self._sample_commands(int(due.sum()))

    def _episode_info(self, done: torch.Tensor) -> dict:
        steps = self.episode_step.clamp(min=1).float()
        errors = {name: sums / steps for name, sums in self.tracking_error_sums.items()}
        return self.outcomes.info({**self.episode_end(done, self.exception), **errors}, self.episode_sums, errors)

    @classmethod
    def validate(cls, cfg: dict) -> None:
        """Check the robot and the terms (events included) before anything is built."""
        if backend_name(cfg["lowlevel"]) != "go1":
            raise BadInput(
                f"level=locomotion trains the Go1, not lowlevel={cfg['lowlevel']['name']}; valid: lowlevel=go1"
            )
        super().validate(cfg)
        event_specs(cfg["level"], evaluation=False)


def proprioceptive_observation(env) -> torch.Tensor:
    """The Go1's own senses (`go1.proprioception`, 45 numbers), as the go1 backend computes them: (E, 45)."""
    sensed = proprioception(
        env.robot_qpos, env.robot_qvel, env.commands.numpy(), env.actions.numpy(), env.default_pose
    ).astype(np.float32)
    return torch.from_numpy(sensed)


def body_linear_velocity(env) -> torch.Tensor:
    """The trunk's body-frame linear velocity (3), which the robot cannot measure (critic only): (E, 3)."""
    return env.state.lin_vel
