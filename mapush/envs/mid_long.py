"""The M+L baselines' env: the mid level alone, pushing straight to the distant final target (paper IV-A-2).

The long-horizon map of the high level (`conf/map/long_horizon.yaml`: start and goal areas 10+ m apart, obstacle
blocks between them) with no high level: the final target is the mid level's only subgoal, for the whole 160 s
episode. Everything else (observation, action, rewards, exceptions) is the mid env's, so `reward.terms.ocb=null`
gives M+L and the full mid reward M+L FT. Obstacles are physical; touching them is not an exception (the mid
level's exceptions do not include them).
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.envs.mid import MidPushEnv
from mapush.envs.resets import sample_high_layout, sample_obstacles
from mapush.planning.geometry import corners
from mapush.sim.core import BatchSim


class LongMidPushEnv(MidPushEnv):
    """E envs x A robots pushing an object to a target 10+ m away through obstacles, with no high level."""

    def _make_sim(self) -> BatchSim:
        spec = self.cfg["level"]["obstacles"]
        self.num_obstacles = spec["count"]
        self.target_xy = torch.zeros(self.num_envs, 2)
        self.obstacle_corners = torch.zeros(self.num_envs, self.num_obstacles, 4, 2)
        return BatchSim(self.cfg["sim"], self.cfg["task"], self.lowlevel, self.num_envs, spec["count"], spec["size"])

    def _sample_layout(self, n: int) -> dict[str, torch.Tensor]:
        layout = sample_high_layout(self.generator, n, self.cfg)
        layout["subgoal_xy"] = layout["target_xy"]  # the final target is the subgoal
        return layout

    def reset(self, ids: np.ndarray) -> None:
        """Start new episodes: the mid env's reset on a long-horizon layout, then obstacles between start and goal."""
        if len(ids) == 0:
            return
        super().reset(ids)
        t = torch.from_numpy(ids)
        self.target_xy[t] = self.subgoal_xy[t]
        obstacles = sample_obstacles(self.generator, self.cfg, self.object_xy[t], self.target_xy[t], None)
        self.obstacle_corners[t] = corners(obstacles)
        self.sim.set_obstacles(ids, obstacles)  # fixed blocks: the robots' and object's state is unchanged

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """The mid env's frame plus the final target and the obstacles' footprints."""
        return {**super().scene_frame(), "target_xy": self.target_xy, "obstacles": self.obstacle_corners}
