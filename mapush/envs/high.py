"""The high-level env: a centralized policy picks the object's next subgoal; the frozen mid level pushes it there.

One decision every `level.decision_steps` mid-level steps (0.5 s; the original: 20 ms). Success: the object
within `success_distance` of the final target, 10+ m away through obstacles. Exceptions (`level.exceptions`) are
penalized; those in `level.terminal_exceptions` also end the episode (by default not the contacts, as in the
original's evaluation: docs/fidelity.md).

The observation (`observations.high_observation`) is in the *target frame*: origin at the object, x toward the
final target. Action: 2 numbers in [-1, 1]; the subgoal lies d = d_min + (a1 + 1) / 2 (d_max - d_min) (1.5-3 m,
the mid level's trained range) from the object, turned by a0 * `subgoal_max_turn` from the *path direction*
(object -> the path point `path_direction_m` ahead of its nearest one). a = (0, 0) follows the path at 2.25 m.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from mapush.envs import observations as obs_terms
from mapush.envs.base import exception_names
from mapush.envs.pushing import PushEnv
from mapush.envs.resets import sample_high_layout, sample_obstacles
from mapush.errors import BadInput
from mapush.planning.geometry import near_gaps, rectangles, rotate, transform
from mapush.planning.paths import nearest_index, path_spacing, random_curved_paths, remaining_length
from mapush.sim.shapes import object_radius


class HighPushEnv(PushEnv):
    """E envs, each a team of A robots under one high-level policy, pushing an object 10+ m through obstacles.

    Args:
        cfg: the composed config (plain dict) with `level=high`.
        mid: the frozen mid level (`mapush.rl.frozen.load_mid_policy`).
        num_envs: overrides `cfg["num_envs"]`.
        planner: an `ObjectPlanner` to plan every episode's reference path among obstacles placed as at
            evaluation (evaluation, and training by default); None draws the paper's random curved paths with
            obstacles beside them (training with `level.path.plan_in_training=false`).
        evaluation: an evaluation env (`PushEnv`: no drawn robot dynamics; `mapush.levels.make_env` passes the
            planner that evaluation asks for).
    """

    def __init__(self, cfg: dict, mid=None, num_envs: int | None = None, planner=None, evaluation: bool = False):
        level = cfg["level"]
        super().__init__(
            cfg, num_envs, self.policy_rows(cfg), decision_steps=int(level["decision_steps"]), evaluation=evaluation
        )
        self.mid = mid
        self.planner = planner
        self.decision_steps = int(level["decision_steps"])
        self.frame_dt = self.sim_dt  # recorders see every mid-level step
        self.num_actions = 2  # per policy row: the subgoal's turn and distance, each in [-1, 1]
        self.object_radius = object_radius(cfg["task"]["object"])
        self.robot_size = tuple(cfg["lowlevel"]["size"][:2])
        E = self.num_envs
        self.inner_step = torch.zeros(E, dtype=torch.long)  # mid-level steps; `episode_step` counts decisions
        self.target_xy = torch.zeros(E, 2)
        self.path = torch.zeros(E, level["path"]["points"], 2)
        self.target_distance = torch.zeros(E)
        self.plan_failed = torch.zeros(E, dtype=torch.bool)
        # `exception`: an exception in the latest decision (the penalty); `failed`: a terminal one, which ends the
        # episode as a failure and names `exception_kind`
        self.failed = torch.zeros(E, dtype=torch.bool)
        self.exception_decisions = torch.zeros(E)  # decisions with an exception, this episode
        self.terminal = torch.tensor([k in level["terminal_exceptions"] for k in self.exception_names])
        self.reset(np.arange(E))

    @staticmethod
    def policy_rows(cfg: dict) -> int:
        """Policy rows per env: one centralized decision per team."""
        return 1

    @classmethod
    def validate(cls, cfg: dict) -> None:
        """Check a high-level config before anything is built: the push checks, the terminal exceptions and the
        held reward terms."""
        super().validate(cfg)
        names = exception_names(cfg)
        unknown = set(cfg["level"]["terminal_exceptions"]) - set(names)
        if unknown:
            raise BadInput(f"unknown level.terminal_exceptions {sorted(unknown)}; valid: {', '.join(names)}")
        terms = cfg["reward"]["terms"]
        for name in cfg["level"]["hold_at_target"]:
            if name not in terms:
                raise BadInput(f"level.hold_at_target names {name!r}, not a reward term; valid: {', '.join(terms)}")

    @property
    def episode_time_s(self) -> torch.Tensor:
        """Simulated time of each env's episode, s (per mid-level step)."""
        return self.inner_step.float() * self.sim_dt

    # ----------------------------------------------------------------------------------------------------------
    def _start_episodes(self, ids: np.ndarray, t: torch.Tensor) -> None:
        """Layout, reference path and obstacles of new episodes in envs `ids`."""
        level = self.cfg["level"]
        layout = sample_high_layout(self.generator, len(ids), self.cfg)
        start, target = layout["object_xy"], layout["target_xy"]
        points = level["path"]["points"]
        if self.planner is None:
            path = random_curved_paths(self.generator, start, target, level["path"]["train_noise"], points)
            obstacles = sample_obstacles(self.generator, self.cfg, start, target, path)
            failed = torch.zeros(len(ids), dtype=torch.bool)
        else:
            obstacles = sample_obstacles(self.generator, self.cfg, start, target, None)
            path, failed = self._plan(start, target, obstacles, points)
        self.sim.reset(ids, layout)
        self.target_xy[t], self.path[t] = target, path
        self.set_obstacles(ids, obstacles)
        self.subgoal_xy[t] = layout["subgoal_xy"]
        self.plan_failed[t] = failed
        self.inner_step[t] = 0
        self.success[t] = False
        self.exception[t] = False
        self.failed[t] = False
        self.exception_kind[t] = -1
        self.exception_decisions[t] = 0.0

    def _plan(self, start, target, obstacles, points) -> tuple[torch.Tensor, torch.Tensor]:
        """OMPL paths for each env (a straight line where planning fails, which ends that episode at once)."""
        paths, failed = [], []
        for s, g, obs in zip(start.numpy(), target.numpy(), obstacles.numpy(), strict=True):
            result = self.planner.plan(s, g, obs, points)
            if result.solved and result.valid:
                paths.append(torch.from_numpy(result.path))
                failed.append(False)
            else:
                paths.append(torch.from_numpy(np.linspace(s, g, points)).float())
                failed.append(True)
        return torch.stack(paths), torch.tensor(failed)

    def _read_state(self) -> None:
        """The simulation state, the target distance and the gaps to the obstacles."""
        super()._read_state()
        s = self.state
        self.target_distance = torch.linalg.vector_norm(s.object_xy - self.target_xy, dim=-1)
        if self.num_obstacles:
            hull = transform(self.hull, s.object_xy, s.object_yaw)  # (E, H, 2)
            self.object_obstacle_gap = near_gaps(
                s.object_xy.unsqueeze(1),
                self.object_radius,
                hull.unsqueeze(1),
                self.obstacles,
                self.obstacle_corners,
            )[:, 0]  # (E, K)
            boxes = rectangles(s.robot_xy, s.robot_yaw, *self.robot_size)  # (E, A, 4, 2)
            robot_radius = math.hypot(*self.robot_size) / 2
            self.robot_obstacle_gap = near_gaps(s.robot_xy, robot_radius, boxes, self.obstacles, self.obstacle_corners)
        else:
            self.object_obstacle_gap = torch.full((self.num_envs, 1), float("inf"))
            self.robot_obstacle_gap = torch.full((self.num_envs, self.num_agents, 1), float("inf"))

    # ----------------------------------------------------------------------------------------------------------
    def path_direction(self) -> torch.Tensor:
        """Unit vector from the object toward the path point `path_direction_m` past its nearest one: (E, 2)."""
        ahead = self.path_points_ahead(torch.tensor([self.cfg["level"]["path_direction_m"]]))[:, 0]
        d = ahead - self.state.object_xy
        norm = torch.linalg.vector_norm(d, dim=-1, keepdim=True)
        fallback = self.target_xy - self.state.object_xy
        d = torch.where(norm > 1e-3, d, fallback)
        return d / torch.linalg.vector_norm(d, dim=-1, keepdim=True).clamp(min=1e-6)

    def path_points_ahead(self, distances: torch.Tensor) -> torch.Tensor:
        """Path points at the given arc lengths (L,) past the point nearest the object: (E, L, 2)."""
        points = self.path.shape[1]
        spacing = path_spacing(self.path)
        idx = nearest_index(self.path, self.state.object_xy).unsqueeze(1)
        offset = torch.round(distances.unsqueeze(0) / spacing.unsqueeze(1).clamp(min=1e-3)).long()
        ahead = (idx + offset).clamp(max=points - 1)
        return self.path.gather(1, ahead.unsqueeze(-1).expand(-1, -1, 2))

    def subgoal_from_action(self, actions: torch.Tensor) -> torch.Tensor:
        """Subgoals (E, 2) from actions (E, 2) in [-1, 1] (parametrization in the module docstring)."""
        level = self.cfg["level"]
        a = actions.clamp(-1.0, 1.0)
        d_min, d_max = level["subgoal_distance"]
        distance = d_min + (a[:, 1] + 1) / 2 * (d_max - d_min)
        base = self.path_direction()
        direction = rotate(base, a[:, 0] * level["subgoal_max_turn"])
        return self.state.object_xy + direction * distance.unsqueeze(-1)

    # ----------------------------------------------------------------------------------------------------------
    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """One decision: set the subgoals, run `decision_steps` mid-level steps, then score and reset.

        Args:
            actions: (E, 1, 2) raw policy outputs.

        Returns:
            obs, rewards (E, 1), terminated (E,), truncated (E,), info (`log`, `episode_end`) as `MidPushEnv.step`.
        """
        level = self.cfg["level"]
        self._apply_action(actions.reshape(self.num_envs, self.policy_agents, self.num_actions))
        # where the object stood on its path when the decision began (reward `path_progress`)
        self.path_remaining_at_decision = remaining_length(self.path, self.state.object_xy)
        finished = self.success | self.failed  # latched within the decision
        diverged_any = torch.zeros(self.num_envs, dtype=torch.bool)
        self.exception = torch.zeros(self.num_envs, dtype=torch.bool)
        for k in range(self.decision_steps):
            commands = self._commands()
            failed = self._advance(commands, ~finished)
            self.inner_step += (~finished).long()
            self.diverged = self._divergence(failed)
            diverged_any |= self.diverged
            kinds = self.exception_flags() & ~finished  # (kinds, E)
            self.exception |= kinds.any(0)
            terminal = kinds & self.terminal.unsqueeze(1)
            new_failure = terminal.any(0)
            new_success = (self.target_distance < level["success_distance"]) & ~finished & ~new_failure
            self.exception_kind = torch.where(new_failure, terminal.int().argmax(0), self.exception_kind)
            self.failed |= new_failure
            self.success |= new_success
            finished = finished | new_failure | new_success
            if self.recorders:
                last = k == self.decision_steps - 1
                done_now = self._done_after_decision(finished) if last else torch.zeros_like(finished)
                for recorder in self.recorders:
                    recorder.capture(self, commands, self.last_reward, self.last_parts, done_now)
        self.diverged = diverged_any
        self.episode_step += 1
        self.exception_decisions += self.exception.float()
        terminated = self.success | self.failed
        truncated = (self.episode_step >= self.max_episode_length) & ~terminated
        reward, parts = self.rewards.compute(self)
        if level["hold_at_target"]:
            extra = self._hold_factor(self.success).unsqueeze(-1) - 1.0
            reward = reward + extra * sum(parts[name] for name in level["hold_at_target"])
        return self._finish_step(reward, parts, terminated, truncated, None)

    def _apply_action(self, actions: torch.Tensor) -> None:
        """Start a decision: the object's subgoal from the actions (E, 1, 2), shown by the subgoal marker; with
        `level.follow_path` the actions are ignored and the subgoal follows the path (action (0, 0))."""
        if self.cfg["level"]["follow_path"]:
            actions = torch.zeros_like(actions)
        self.subgoal_xy = self.subgoal_from_action(actions[:, 0])
        self.sim.set_subgoal(np.arange(self.num_envs), self.subgoal_xy)

    def _commands(self) -> torch.Tensor:
        """Every robot's (vx, vy, yaw rate) command (E, A, 3) for the next step: the frozen mid level's."""
        return self.mid.commands(obs_terms.local_observation(self))

    def _hold_factor(self, success: torch.Tensor) -> torch.Tensor:
        """Per-env multiplier (E,): sum_{k<R} gamma^k for envs that succeeded, R the decisions left; else 1.

        Success ends the episode, but the task terms are positive every decision, so a plain ending would forfeit
        them for the decisions up to the timeout and teach the policy to dawdle short of the target. The terms
        named in `level.hold_at_target` are paid as if the object stayed at the target until the timeout: once
        for each remaining decision, discounted with the algorithm's gamma. Penalties are paid once.
        """
        gamma = float(self.cfg["algo"]["algorithm"]["gamma"])
        left = (self.max_episode_length - self.episode_step + 1).clamp(min=1).float()
        factor = (1.0 - gamma**left) / (1.0 - gamma) if gamma < 1.0 else left
        return torch.where(success, factor, torch.ones_like(factor))

    def _done_after_decision(self, finished: torch.Tensor) -> torch.Tensor:
        return finished | (self.episode_step + 1 >= self.max_episode_length)

    def _episode_info(self, done: torch.Tensor) -> dict:
        end = {**self.episode_end(done, self.failed), "planner_failure": self.plan_failed & done}
        return self.outcomes.info(end, self.episode_sums, {"exception_decisions": self.exception_decisions})

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env: poses, subgoal, target, obstacles (corners) and the reference path."""
        return {
            **super().scene_frame(),
            "target_xy": self.target_xy,
            "obstacles": self.obstacle_corners,
            "path": self.path,
        }
