"""Mid-level reward terms (paper App. B). Each returns the unweighted term, Shape: (num_envs, num_agents).

Terms read the env's state (`env.state`, a `PushState`: `object_xy`, `robot_xy`, ...) and flags (`env.success`,
`env.exception`); they run after the physics step and before finished envs are reset.
"""

from __future__ import annotations

import torch

from mapush.errors import BadInput
from mapush.planning.geometry import rotate
from mapush.planning.paths import distance_to_path


def _shared(env, value: torch.Tensor) -> torch.Tensor:
    """Broadcast a per-env value (E,) to every policy row of the env: (E, A) mid level, (E, 1) high level."""
    return value.float().unsqueeze(1).expand(-1, env.policy_agents)


def subgoal_reached(env) -> torch.Tensor:
    """1 on the step the object centre comes within the success distance of the subgoal; shared."""
    return _shared(env, env.success)


def subgoal_progress(env, alpha: float) -> torch.Tensor:
    """alpha * (d_{t-1} - d_t) - d_t, with d the object-subgoal distance in m; shared (paper: alpha = 200)."""
    d = env.subgoal_distance
    return _shared(env, alpha * (env.prev_subgoal_distance - d) - d)


def exception(env) -> torch.Tensor:
    """1 when the episode ends in an exception (fall, robot collision, object tilt, NaN); shared."""
    return _shared(env, env.exception)


def agent_proximity(env) -> torch.Tensor:
    """sum over the other robots j of 1 / (0.02 + d_ij / 3), d_ij the distance between robot centres in m."""
    near = 1.0 / (0.02 + env.state.robot_distance / 3.0)
    return near.sum(-1) - 1.0 / 0.02  # drop j = i, where d_ii = 0


def object_approach(env) -> torch.Tensor:
    """-(d_i + 0.5)^2, d_i the distance from robot i to the object centre in m."""
    d = torch.linalg.vector_norm(env.state.robot_xy - env.state.object_xy.unsqueeze(1), dim=-1)
    return -((d + 0.5) ** 2)


def object_moving(env, min_speed: float) -> torch.Tensor:
    """1 while the object's planar speed exceeds `min_speed` m/s; shared."""
    return _shared(env, torch.linalg.vector_norm(env.state.object_vel[:, :2], dim=-1) > min_speed)


def occlusion_based(env) -> torch.Tensor:
    """OCB (paper III-E-1): inward normal of the object's hull at the point closest to robot i, dotted with the
    unit vector from the object to the subgoal. +1 behind the object (the pushing side), -1 in front of it."""
    to_goal = env.subgoal_xy - env.state.object_xy
    to_goal = to_goal / torch.linalg.vector_norm(to_goal, dim=-1, keepdim=True).clamp_min(1e-6)
    normal = hull_inward_normal(env.hull, env.state.object_xy, env.state.object_yaw, env.state.robot_xy)
    return (normal * to_goal.unsqueeze(1)).sum(-1)


def hull_inward_normal(
    hull: torch.Tensor, object_xy: torch.Tensor, object_yaw: torch.Tensor, points: torch.Tensor
) -> torch.Tensor:
    """Inward unit normal of a convex polygon at the boundary point closest to each query point, in the world frame.

    Outside the hull this is the unit vector from the point to its closest boundary point (at an edge it is the
    edge's inward normal, at a vertex it turns continuously between the two edges' normals). Inside (possible
    in the T-block's notches) it is the inward normal of the closest edge.

    Args:
        hull: CCW vertices in the object frame, (V, 2).
        object_xy: (E, 2). object_yaw: (E,). points: (E, A, 2), world frame.

    Returns:
        Shape: (E, A, 2).
    """
    q = rotate(points - object_xy.unsqueeze(1), object_yaw, inverse=True)  # R(-yaw) (p - b): in the object frame
    edge = torch.roll(hull, -1, 0) - hull  # (V, 2), edge k from vertex k to k + 1
    (sx, sy), (ex, ey) = hull.unbind(-1), edge.unbind(-1)
    # per-component (E, A, V) tensors: the cylinder's 64-gon makes this the costliest reward term
    dx, dy = q[..., 0:1] - sx, q[..., 1:2] - sy  # from each edge's start to the point
    t = ((dx * ex + dy * ey) / (ex * ex + ey * ey)).clamp(0.0, 1.0)  # the closest point's place along the edge
    gx, gy = (sx + t * ex) - q[..., 0:1], (sy + t * ey) - q[..., 1:2]  # from the point to it
    # nearest edge; vector_norm rounds as the earlier code did, so near-ties (a shared vertex) pick the same edge
    k = torch.linalg.vector_norm(torch.stack([gx, gy], -1), dim=-1).argmin(-1, keepdim=True)
    gap_k = torch.stack([gx.gather(2, k), gy.gather(2, k)], -1).squeeze(2)  # (E, A, 2)
    dist_k = torch.linalg.vector_norm(gap_k, dim=-1)
    edge_k = edge[k.squeeze(-1)]
    edge_normal = torch.stack([-edge_k[..., 1], edge_k[..., 0]], -1)  # left normal: inward for CCW
    edge_normal = edge_normal / torch.linalg.vector_norm(edge_normal, dim=-1, keepdim=True)
    inside = (dx * ey - dy * ex <= 0).all(-1)  # left of (or on) every edge
    use_gap = (~inside) & (dist_k > 1e-6)
    n = torch.where(use_gap.unsqueeze(-1), gap_k / dist_k.clamp_min(1e-6).unsqueeze(-1), edge_normal)
    # back to the world frame: R(yaw) n
    return rotate(n, object_yaw)


# ---------------------------------------------------------------------------------------------------------------
# High level (paper App. B, "high reward"): one team reward per decision, (E, 1).


def target_reached(env) -> torch.Tensor:
    """1 on the decision in which the object comes within the success distance of the final target."""
    return _shared(env, env.success)


def target_approach(env) -> torch.Tensor:
    """1 / (1 + d), d the object-target distance in m."""
    return _shared(env, 1.0 / (1.0 + env.target_distance))


PATH_FOLLOWERS = ("subgoal", "object")
"""What `path_following` measures against the path: the chosen subgoal (paper) or the object (H+L, no subgoal)."""


def path_following(env, point: str = "subgoal") -> torch.Tensor:
    """1 / (1 + d), d from the chosen subgoal (or the object, `point="object"`) to the nearest sampled point of
    the reference path. The configs name `point`; the default is for runs saved before it existed."""
    if point not in PATH_FOLLOWERS:
        raise BadInput(f"path_following point {point!r}; valid: {', '.join(PATH_FOLLOWERS)}")
    xy = env.subgoal_xy if point == "subgoal" else env.state.object_xy
    return _shared(env, 1.0 / (1.0 + distance_to_path(env.path, xy)))


def obstacle_proximity(env) -> torch.Tensor:
    """1 / (1 + d), d from the object's footprint to the nearest obstacle's, in m (0 when touching)."""
    return _shared(env, 1.0 / (1.0 + env.object_obstacle_gap.amin(-1).clamp(min=0.0)))
