"""Go-to-point: turn each robot's navigation goal into a (vx, vy, yaw rate) command for any low-level backend.

The H+L baselines' high level gives every robot a point to walk to (paper IV-A-2, after Nachum et al. 2019); this
proportional controller is how the low level executes it. The body-frame velocity points at the goal, its size
`gain` times the distance, scaled down as one vector until both axes are within their limits; the yaw rate turns
the robot toward the goal while it is more than `arrive_m` away. The limits are the mid level's `action_scale`, so
H+L commands the robots over the same range as the mid level does.
"""

from __future__ import annotations

import torch

from mapush.planning.geometry import rotate


def go_to_point(
    robot_xy: torch.Tensor,
    robot_yaw: torch.Tensor,
    goal_xy: torch.Tensor,
    limits: torch.Tensor,
    gain: float,
    yaw_gain: float,
    arrive_m: float,
) -> torch.Tensor:
    """Body-frame commands (E, A, 3) that walk robots at `robot_xy` (E, A, 2), `robot_yaw` (E, A) to `goal_xy`.

    Args:
        limits: (3,) the largest |vx| m/s, |vy| m/s and |yaw rate| rad/s.
        gain: 1/s, velocity per metre of distance to the goal.
        yaw_gain: 1/s, yaw rate per radian between the heading and the goal's bearing.
        arrive_m: within this distance the robot stops turning (the bearing is meaningless at the goal).
    """
    offset = goal_xy - robot_xy
    body = rotate(offset, robot_yaw, inverse=True)
    velocity = gain * body
    over = (velocity.abs() / limits[:2]).amax(-1, keepdim=True).clamp(min=1.0)
    velocity = velocity / over  # keeps the direction
    distance = torch.linalg.vector_norm(offset, dim=-1)
    bearing = torch.atan2(body[..., 1], body[..., 0])  # already relative to the heading, in (-pi, pi]
    yaw_rate = (yaw_gain * bearing).clamp(-limits[2], limits[2])
    yaw_rate = torch.where(distance > arrive_m, yaw_rate, torch.zeros_like(yaw_rate))
    return torch.cat([velocity, yaw_rate.unsqueeze(-1)], -1)
