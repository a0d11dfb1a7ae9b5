"""The H+L baselines' env: a multi-agent high level gives each robot a navigation goal; no mid level.

Paper IV-A-2 (after Nachum et al. 2019): the high level proposes per-robot subgoals directly to the low level and
is trained with MAPPO. Here each robot is one policy row (shared weights, the team reward); every
`level.decision_steps` control steps it picks a point for its robot to walk to, and `mapush.lowlevel.goto` turns
that point into the robot's (vx, vy, yaw rate) command at every step until the next decision. Everything else is
the high level's (`HighPushEnv`): the long-horizon map, the reference path (random curves in training, OMPL at
evaluation), the exceptions, success and the episode outcomes.

The object has no subgoal of its own. `subgoal_xy`, which the observation, the marker and the OCB reward read, is
the reference-path point `level.path_direction_m` ahead of the object's nearest one, the direction the team
should push in. Path following (`reward/high_nav.yaml`) measures the object's distance to the path.

Action of robot i: 2 numbers in [-1, 1], its goal's offset from the robot in the target frame (x toward the final
target) times `level.robot_goal_range_m`. Observation of robot i (`conf/level/high_nav.yaml`): the high level's
centralized view (`high_observation`) | the robot's xy and yaw (cos, sin) in the target frame | its current goal
relative to it, in the target frame | its one-hot index (width `high_obs_dim + 6 + A`).

With `level.follow_path` the policy is ignored: `scripted_goals` leads the robots along the planned path, what the
action space allows with no learning (the reference the learned H+L baselines are held against).
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.envs.high import HighPushEnv
from mapush.envs.observations import high_obs_dim, target_heading
from mapush.lowlevel.goto import go_to_point
from mapush.planning.geometry import rotate


class NavHighPushEnv(HighPushEnv):
    """E envs, each a team of A robots, each robot led by its own navigation goal (the H+L baselines)."""

    def __init__(self, cfg: dict, mid=None, num_envs: int | None = None, planner=None, evaluation: bool = False):
        E, A = num_envs or cfg["num_envs"], cfg["task"]["num_agents"]
        self.robot_goal_xy = torch.zeros(E, A, 2)  # filled by reset()
        goto = cfg["level"]["goto"]
        self.goto_limits = torch.tensor(goto["limits"], dtype=torch.float32)
        super().__init__(cfg, None, num_envs, planner, evaluation)

    @staticmethod
    def policy_rows(cfg: dict) -> int:
        return cfg["task"]["num_agents"]  # one row per robot (MAPPO)

    def _started(self, t: torch.Tensor) -> None:
        """Every robot starts with its own position as its goal."""
        self.robot_goal_xy[t] = self.state.robot_xy[t]
        self.subgoal_xy[t] = self._push_direction_point()[t]

    def _push_direction_point(self) -> torch.Tensor:
        """The reference-path point `path_direction_m` ahead of the object's nearest one: (E, 2)."""
        return self.path_points_ahead(torch.tensor([self.cfg["level"]["path_direction_m"]]))[:, 0]

    def _apply_action(self, actions: torch.Tensor) -> None:
        """Every robot's goal from its action (E, A, 2) in [-1, 1], or with `level.follow_path` from
        `scripted_goals`; the marker shows the push direction point."""
        self.subgoal_xy = self._push_direction_point()
        if self.cfg["level"]["follow_path"]:
            self.robot_goal_xy = self.scripted_goals()
        else:
            offset = actions.clamp(-1.0, 1.0) * self.cfg["level"]["robot_goal_range_m"]
            self.robot_goal_xy = self.state.robot_xy + rotate(offset, target_heading(self))
        self.sim.set_subgoal(np.arange(self.num_envs), self.subgoal_xy)

    def scripted_goals(self) -> torch.Tensor:
        """(E, A, 2) goals of the hand-written pusher: the push direction u points from the object to the path
        point ahead (`subgoal_xy`); a robot behind the object within `reach_m` of the push line walks on along u,
        any other to its staging slot `behind_m` behind the object, spread sideways by its index. Each goal lies
        within the action range of its robot, as a policy's would."""
        s, scripted = self.state, self.cfg["level"]["scripted"]
        reach, behind = scripted["reach_m"], scripted["behind_m"]
        u = self.subgoal_xy - s.object_xy
        u = u / torch.linalg.vector_norm(u, dim=-1, keepdim=True).clamp_min(1e-6)  # (E, 2)
        side = torch.stack([-u[:, 1], u[:, 0]], -1)
        rel = s.robot_xy - s.object_xy.unsqueeze(1)  # (E, A, 2)
        along, across = (rel * u.unsqueeze(1)).sum(-1), (rel * side.unsqueeze(1)).sum(-1)
        pushing = (along < 0) & (across.abs() < reach)
        A = self.num_agents
        spread = (torch.arange(A) - (A - 1) / 2) * (2 * reach / max(A, 1))  # sideways slots behind the object
        staging = s.object_xy.unsqueeze(1) - behind * u.unsqueeze(1) + spread.view(1, A, 1) * side.unsqueeze(1)
        onward = s.robot_xy + 2.0 * u.unsqueeze(1)
        goal = torch.where(pushing.unsqueeze(-1), onward, staging)
        heading = target_heading(self).unsqueeze(1).expand(-1, A)
        reach_box = self.cfg["level"]["robot_goal_range_m"]
        offset = rotate(goal - s.robot_xy, -heading).clamp(-reach_box, reach_box)  # the action range
        return s.robot_xy + rotate(offset, heading)

    def _commands(self) -> torch.Tensor:
        goto = self.cfg["level"]["goto"]
        return go_to_point(
            self.state.robot_xy,
            self.state.robot_yaw,
            self.robot_goal_xy,
            self.goto_limits,
            goto["gain"],
            goto["yaw_gain"],
            goto["arrive_m"],
        )

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """The high level's frame plus every robot's navigation goal."""
        return {**super().scene_frame(), "robot_goal_xy": self.robot_goal_xy}


def nav_high_obs_dim(cfg: dict) -> int:
    """Width of `NavHighPushEnv.observations` for a config (`conf/level/high_nav.yaml`)."""
    return high_obs_dim(cfg) + 6 + cfg["task"]["num_agents"]
