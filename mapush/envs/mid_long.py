"""The M+L baselines' env: the mid level alone, pushing straight to the distant final target (paper IV-A-2).

The long-horizon map of the high level (`conf/map/long_horizon.yaml`: start and goal areas 10+ m apart, obstacle
blocks between them) with no high level: the final target is the mid level's only subgoal, for the whole 160 s
episode. Everything else (observation, action, rewards, exceptions) is the mid env's, so `reward.terms.ocb=null`
gives M+L and the full mid reward M+L FT. Obstacles are physical; touching them is not an exception (the mid
level's exceptions do not include them).
"""

from __future__ import annotations

import torch

from mapush.envs.mid import MidPushEnv
from mapush.envs.resets import sample_high_layout, sample_obstacles


class LongMidPushEnv(MidPushEnv):
    """E envs x A robots pushing an object to a target 10+ m away through obstacles, with no high level."""

    def __init__(self, cfg: dict, num_envs: int | None = None, evaluation: bool = False):
        self.target_xy = torch.zeros(num_envs or cfg["num_envs"], 2)
        super().__init__(cfg, num_envs, evaluation)

    def _sample_layout(self, n: int) -> dict[str, torch.Tensor]:
        layout = sample_high_layout(self.generator, n, self.cfg)
        layout["subgoal_xy"] = layout["target_xy"]  # the final target is the subgoal
        return layout

    def _started(self, t: torch.Tensor) -> None:
        """The final target, then obstacles between start and goal (fixed blocks: the robots' and object's state
        is unchanged)."""
        super()._started(t)
        self.target_xy[t] = self.subgoal_xy[t]
        obstacles = sample_obstacles(self.generator, self.cfg, self.state.object_xy[t], self.target_xy[t], None)
        self.set_obstacles(t.numpy(), obstacles)

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """The mid env's frame plus the final target and the obstacles' footprints."""
        return {**super().scene_frame(), "target_xy": self.target_xy, "obstacles": self.obstacle_corners}
