"""The low level: a Go1 learns to track (vx, vy, yaw rate) commands on flat ground (paper III-B; architecture 2).

E single-robot MuJoCo sims stepped together by `mujoco.batch`; no Python loop over envs. The policy acts at 50 Hz:
its 12 actions are joint-angle offsets from the standing pose (times `lowlevel.action_scale`), which the model's PD
servos track at 200 Hz (every 5 ms physics step), capped at the Go1's motor torques (`go1_constants`).

Observation: the robot's own senses (`go1.proprioception`, 45 numbers, shared with the go1 backend that later runs
the policy under the pushing levels). The critic also gets the body-frame linear velocity (3), which the robot
cannot measure. Servo gains and the action scale are the go1 backend's (`conf/lowlevel/go1.yaml`).

Commands are drawn per env from `level.commands` at reset and every `resample_s`; a `zero_fraction` of them are
"stand still". Evaluation draws them from `level.eval_commands`, the range the mid level commands, and pushes with
`level.eval_push_velocity` (0 by default: the tracking target is on flat ground, undisturbed).

Domain randomization: ground and foot friction and an added trunk mass, drawn once per env, and a random push (a
change of the trunk's horizontal velocity) every `push_interval_s`. A fall (trunk too low, tilted too far, or
touching the ground) ends the episode as an exception; reaching the timeout is a success.
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np
import torch
from mujoco import batch as mjb

from mapush.envs.common import EpisodeOutcomes, episode_end
from mapush.errors import BadInput
from mapush.logging.go1_scene import Go1Layout, drawn_geom_ids, quat_multiply
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import proprioception, rotate_into_body, rotate_into_world
from mapush.lowlevel.go1_model import standalone_spec
from mapush.rewards.manager import RewardManager


def locomotion_model(cfg: dict) -> mujoco.MjModel:
    """One Go1 on flat ground with the go1 backend's servo gains and the sim's timestep."""
    return standalone_spec(cfg["lowlevel"]["kp"], cfg["lowlevel"]["kd"], cfg["sim"]["timestep"]).compile()


class LocomotionEnv:
    """E Go1s on flat ground, each tracking its own velocity command; see the module docstring."""

    EXCEPTIONS = ("diverged", "fall")

    def __init__(self, cfg: dict, num_envs: int | None = None, evaluation: bool = False):
        self.validate(cfg)
        self.cfg = cfg
        level, sim = cfg["level"], cfg["sim"]
        self.command_ranges = level["eval_commands" if evaluation else "commands"]
        self.push_velocity = level["eval_push_velocity"] if evaluation else level["randomize"]["push_velocity"]
        self.num_envs = E = num_envs or cfg["num_envs"]
        self.num_agents = self.policy_agents = 1
        self.num_actions = 12
        self.robot = cfg["lowlevel"]  # servo gains and action scale: the go1 backend's, which runs the policy later
        self.model = locomotion_model(cfg)
        self.decimation = sim["decimation"]
        self.dt = float(self.model.opt.timestep) * self.decimation
        self.frame_dt = self.dt
        self.max_episode_length = math.ceil(level["episode_length_s"] / self.dt - 1e-9)
        nthread = sim["nthread"] or os.cpu_count() or 1
        self.batch = mjb.Batch(self.model, nsim=E, nthread=min(nthread, E))
        b = self.batch
        self.qpos, self.qvel, self.ctrl = b.bind("qpos"), b.bind("qvel"), b.bind("ctrl")
        self.geom_xpos, self.actuator_force = b.bind("geom_xpos"), b.bind("actuator_force")
        self.body_xquat = b.bind("xquat")
        self.feet = np.array([self.model.geom(name).id for name in go1.FOOT_NAMES])
        self.trunk_geom = self.model.geom("trunk_box").id
        self.default_pose = np.array(go1.default_joint_angles())
        self.generator = torch.Generator().manual_seed(int(cfg["seed"]))
        self.rng = np.random.default_rng(int(cfg["seed"]))
        self._randomize_once()
        self.rewards = RewardManager(cfg["reward"]["terms"], cfg["reward"]["positive_only"])
        self.episode_step = torch.zeros(E, dtype=torch.long)
        self.commands = torch.zeros(E, 3)
        self.actions = torch.zeros(E, 12)
        self.last_actions = torch.zeros(E, 12)
        self.air_time = torch.zeros(E, 4)
        self.first_contact = torch.zeros(E, 4, dtype=torch.bool)
        self.success = torch.zeros(E, dtype=torch.bool)
        self.exception = torch.zeros(E, dtype=torch.bool)
        self.exception_kind = torch.full((E,), -1)
        self.velocity_error_sum = torch.zeros(E)
        self.episode_sums = {name: torch.zeros(E, 1) for name in self.rewards.terms}
        self.outcomes = EpisodeOutcomes()
        self.recorders = []  # EpisodeRecorder / LiveView (mapush.logging.episodes) watching some envs
        self.drawn_geoms = np.array(drawn_geom_ids(self.model))
        self.reset(np.arange(E))

    def _randomize_once(self) -> None:
        """Per-env ground and foot friction and added trunk mass (drawn once, as the original drew friction)."""
        rand = self.cfg["level"]["randomize"]
        E = self.num_envs
        friction = self.batch.expand("geom_friction")
        mu = self.rng.uniform(*rand["friction"], size=E)
        floor = self.model.geom("floor").id
        friction[:, floor, 0] = mu
        friction[:, self.feet, 0] = mu[:, None]
        mass = self.batch.expand("body_mass")
        trunk = self.model.body(go1.ROOT_BODY).id
        mass[:, trunk] = self.model.body_mass[trunk] + self.rng.uniform(*rand["added_mass"], size=E)
        self.batch.set_const()

    # ----------------------------------------------------------------------------------------------------------
    def reset(self, ids: np.ndarray) -> None:
        """New episodes in envs `ids`: standing pose (joint angles jittered), random heading, new commands."""
        if len(ids) == 0:
            return
        n = len(ids)
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)
        qpos = np.zeros((n, self.model.nq))
        qpos[:, 2] = go1.standing_height() + 0.02
        yaw = self.rng.uniform(-math.pi, math.pi, size=n)
        qpos[:, 3], qpos[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)
        qpos[:, 7:] = self.default_pose * self.rng.uniform(*self.cfg["level"]["randomize"]["joint_scale"], size=(n, 12))
        self.qpos[ids] = qpos
        self.qvel[ids] = 0.0
        self.ctrl[ids] = self.default_pose
        self.batch.forward(ids)
        t = torch.from_numpy(ids)
        self.commands[t] = self._sample_commands(n)
        self.actions[t] = 0.0
        self.last_actions[t] = 0.0
        self.air_time[t] = 0.0
        self.episode_step[t] = 0
        self.velocity_error_sum[t] = 0.0
        for sums in self.episode_sums.values():
            sums[t] = 0.0
        self._read_state()

    def _sample_commands(self, n: int) -> torch.Tensor:
        spec = self.command_ranges
        low = torch.tensor([spec["vx"][0], spec["vy"][0], spec["yaw_rate"][0]])
        high = torch.tensor([spec["vx"][1], spec["vy"][1], spec["yaw_rate"][1]])
        commands = low + (high - low) * torch.rand(n, 3, generator=self.generator)
        still = torch.rand(n, generator=self.generator) < spec["zero_fraction"]
        return torch.where(still.unsqueeze(-1), torch.zeros_like(commands), commands)

    def _read_state(self) -> None:
        """Body-frame velocities, gravity direction, joints, torques, foot contacts and speeds, as tensors."""
        quat = self.qpos[:, 3:7]
        self.base_height = torch.from_numpy(self.qpos[:, 2].astype(np.float32))
        self.lin_vel = torch.from_numpy(rotate_into_body(quat, self.qvel[:, 0:3]).astype(np.float32))
        self.ang_vel = torch.from_numpy(self.qvel[:, 3:6].astype(np.float32))  # a free joint's is body-frame
        down = np.broadcast_to(np.array([0.0, 0.0, -1.0]), (self.num_envs, 3))
        self.gravity = torch.from_numpy(rotate_into_body(quat, down).astype(np.float32))
        self.torques = torch.from_numpy(self.actuator_force.astype(np.float32))
        feet = torch.from_numpy(self.geom_xpos[:, self.feet].astype(np.float32))  # (E, 4, 3)
        previous = getattr(self, "feet_xyz", feet)
        self.feet_speed = torch.linalg.vector_norm(feet[..., :2] - previous[..., :2], dim=-1) / self.dt
        self.feet_xyz = feet
        self.foot_contact = feet[..., 2] < go1.FOOT_RADIUS + self.cfg["level"]["contact_margin_m"]
        self.trunk_z = torch.from_numpy(self.geom_xpos[:, self.trunk_geom, 2].astype(np.float32))

    @property
    def episode_time_s(self) -> torch.Tensor:
        return self.episode_step.float() * self.dt

    # ----------------------------------------------------------------------------------------------------------
    def observations(self) -> dict[str, torch.Tensor]:
        """`policy` (E, 1, 45): `go1.proprioception`, as the go1 backend computes it; `critic` (E, 1, 48) adds the
        body-frame linear velocity."""
        sensed = proprioception(
            self.qpos, self.qvel, self.commands.numpy(), self.actions.numpy(), self.default_pose
        ).astype(np.float32)
        policy = torch.nan_to_num(torch.from_numpy(sensed), 0.0, 0.0, 0.0)
        critic = torch.cat([policy, torch.nan_to_num(self.lin_vel, 0.0, 0.0, 0.0)], -1)
        return {"policy": policy.unsqueeze(1), "critic": critic.unsqueeze(1)}

    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """One 20 ms policy step. actions: (E, 1, 12). Returns obs, rewards (E, 1), terminated, truncated, info."""
        self.last_actions = self.actions
        clip = self.robot["action_clip"]
        self.actions = actions.reshape(self.num_envs, 12).clamp(-clip, clip)
        self.ctrl[:] = self.default_pose + self.robot["action_scale"] * self.actions.numpy().astype(np.float64)
        diverged = torch.zeros(self.num_envs, dtype=torch.bool)
        try:
            self.batch.step(nstep=self.decimation)
        except mjb.SimulationError as err:
            diverged[torch.as_tensor(np.asarray(err.ids, dtype=np.int64))] = True
        self.episode_step += 1
        self._push()
        self._read_state()
        self._update_air_time()
        diverged |= ~torch.isfinite(self.base_height)
        fall = self._fallen()
        self.exception = diverged | fall
        self.exception_kind = torch.where(diverged, 0, torch.where(fall, 1, -1))
        truncated = (self.episode_step >= self.max_episode_length) & ~self.exception
        self.success = truncated  # a whole episode without a fall
        terminated = self.exception
        reward, parts = self.rewards.compute(self)
        reward = torch.nan_to_num(reward, 0.0, 0.0, 0.0)
        for name, value in parts.items():
            self.episode_sums[name] += torch.nan_to_num(value, 0.0, 0.0, 0.0)
        self.velocity_error_sum += self.velocity_error()
        done = terminated | truncated
        for recorder in self.recorders:
            recorder.capture(self, self.commands.unsqueeze(1), reward, parts, done)
        info = self._episode_info(done, diverged)
        self._resample_commands()
        self.reset(done.nonzero().flatten().numpy())
        return self.observations(), reward, terminated, truncated, info

    @staticmethod
    def scene_layout(cfg: dict) -> Go1Layout:
        """What the episode logs draw of this level: the Go1's geoms."""
        return Go1Layout.from_model(locomotion_model(cfg))

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets): the Go1's geom poses, its trunk, and its commanded
        and actual planar velocity in the world frame (`Go1Layout.scene`)."""
        quat = self.qpos[:, 3:7]
        bodies = self.model.geom_bodyid[self.drawn_geoms]
        command = np.concatenate([self.commands[:, :2].numpy(), np.zeros((self.num_envs, 1))], -1)
        frame = {
            "geom_xpos": self.geom_xpos[:, self.drawn_geoms],
            "geom_xquat": quat_multiply(self.body_xquat[:, bodies], self.model.geom_quat[self.drawn_geoms]),
            "trunk_xyz": self.qpos[:, 0:3],
            "trunk_quat": quat,
            "command_xy": rotate_into_world(quat, command)[:, :2],
            "velocity_xy": self.qvel[:, 0:2],
        }
        return {name: torch.from_numpy(np.ascontiguousarray(value)) for name, value in frame.items()}

    def velocity_error(self) -> torch.Tensor:
        """|commanded - actual| planar velocity, m/s (E,)."""
        return torch.linalg.vector_norm(self.commands[:, :2] - self.lin_vel[:, :2], dim=-1)

    def _fallen(self) -> torch.Tensor:
        fall = self.cfg["level"]["fall"]
        tilt = torch.arccos((-self.gravity[:, 2]).clamp(-1.0, 1.0))
        trunk_on_ground = self.trunk_z - go1.TRUNK_SIZE[2] / 2 < fall["trunk_clearance_m"]
        return (self.base_height < fall["min_height_m"]) | (tilt > fall["max_tilt"]) | trunk_on_ground

    def _update_air_time(self) -> None:
        """Seconds each foot has been off the ground; `first_contact` marks feet that land this step."""
        self.air_time += self.dt
        self.first_contact = (self.air_time > self.dt) & self.foot_contact
        self.landed_air_time = self.air_time * self.first_contact
        self.air_time = self.air_time * ~self.foot_contact

    def _push(self) -> None:
        """Every `push_interval_s`, a random change of each robot's horizontal velocity (m/s)."""
        rand = self.cfg["level"]["randomize"]
        every = max(1, round(rand["push_interval_s"] / self.dt))
        due = ((self.episode_step % every) == 0).numpy()
        if self.push_velocity > 0 and due.any():
            ids = np.flatnonzero(due)
            self.qvel[ids, 0:2] += self.rng.uniform(-1, 1, size=(len(ids), 2)) * self.push_velocity

    def _resample_commands(self) -> None:
        every = max(1, round(self.command_ranges["resample_s"] / self.dt))
        due = (self.episode_step % every == 0) & (self.episode_step > 0)
        if due.any():
            self.commands[due] = self._sample_commands(int(due.sum()))

    def _episode_info(self, done: torch.Tensor, diverged: torch.Tensor) -> dict:
        steps = self.episode_step.clamp(min=1).float()
        end = {**episode_end(self, done, diverged, self.exception), "velocity_error": self.velocity_error_sum / steps}
        return self.outcomes.info(end, self.episode_sums, {"velocity_error": end["velocity_error"]})

    @staticmethod
    def validate(cfg: dict) -> None:
        """Check the robot and the reward terms before anything is built."""
        if cfg["lowlevel"]["name"] != "go1":
            raise BadInput(f"level=low trains the Go1, not lowlevel={cfg['lowlevel']['name']}; valid: lowlevel=go1")
        RewardManager(cfg["reward"]["terms"])
