"""Mid-level reward terms (paper App. B). Each returns the unweighted term, Shape: (num_envs, num_agents).

Terms read the env's state (`env.state`, a `PushState`: `object_xy`, `robot_xy`, ...) and flags (`env.success`,
`env.exception`); they run after the physics step and before finished envs are reset.
"""

from __future__ import annotations

import functools

import torch

from mapush.errors import BadInput
from mapush.planning.paths import distance_to_path, remaining_length


def _shared(env, value: torch.Tensor) -> torch.Tensor:
    """Broadcast a per-env value (E,) to every policy row of the env: (E, A) mid level, (E, 1) high level."""
    return value.float().unsqueeze(1).expand(-1, env.policy_agents)


def subgoal_reached(env) -> torch.Tensor:
    """1 on the step the object centre comes within the success distance of the subgoal; shared."""
    return _shared(env, env.success)


def _approaching(before: torch.Tensor, now: torch.Tensor, alpha: float) -> torch.Tensor:
    """The paper's approaching reward, alpha * (d_{t-1} - d_t) - d_t: progress pays, the distance left costs."""
    return alpha * (before - now) - now


def subgoal_progress(env, alpha: float) -> torch.Tensor:
    """The approaching reward on d, the object-subgoal distance in m; shared (paper: alpha = 200)."""
    return _shared(env, _approaching(env.prev_subgoal_distance, env.subgoal_distance, alpha))


def exception(env) -> torch.Tensor:
    """1 when the episode ends in an exception (fall, robot collision, object tilt, NaN); shared."""
    return _shared(env, env.exception)


def agent_proximity(env) -> torch.Tensor:
    """sum over the other robots j of 1 / (0.02 + d_ij / 3), d_ij the distance between robot centres in m."""
    near = 1.0 / (0.02 + env.state.robot_distance / 3.0)
    return near.sum(-1) - 1.0 / 0.02  # drop j = i, where d_ii = 0


def robot_jam(env, distance_m: float, max_speed: float) -> torch.Tensor:
    """1 for each robot with a teammate's centre within `distance_m` while the object moves slower than `max_speed`
    m/s: teammates body to body and the push stalled (what `mapush logs episodes` counts as jammed)."""
    apart = env.state.robot_distance + torch.eye(env.num_agents) * 1e9  # (E, A, A), no robot near itself
    still = torch.linalg.vector_norm(env.state.object_vel[:, :2], dim=-1) < max_speed
    return ((apart < distance_m).any(-1) & still.unsqueeze(1)).float()


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


@functools.lru_cache(maxsize=16)
def _hull_edges(hull: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """What `hull_inward_normal` needs of a hull (V, 2), computed once per hull tensor (an env's hull is never
    changed in place): edge starts and vectors, unit inward normals (V, 2), the (2, 3V) weights and (3V,) bias of
    its per-edge affine maps (float64), |e_k|^2."""
    start, edge = hull, torch.roll(hull, -1, 0) - hull  # edge k runs from vertex k to k + 1
    length = torch.linalg.vector_norm(edge, dim=-1, keepdim=True)
    left = torch.stack([-edge[:, 1], edge[:, 0]], -1) / length  # unit left normal: inward for CCW
    s, e, n = start.double(), edge.double(), left.double()
    len2 = (e * e).sum(-1)
    weights = torch.cat([e / len2.unsqueeze(1), -2.0 * s, n]).T
    bias = torch.cat([-(s * e).sum(-1) / len2, (s * s).sum(-1), -(s * n).sum(-1)])
    return start, edge, left, weights, bias, len2


def hull_inward_normal(
    hull: torch.Tensor, object_xy: torch.Tensor, object_yaw: torch.Tensor, points: torch.Tensor
) -> torch.Tensor:
    """Inward unit normal of a convex polygon at the boundary point closest to each query point, in the world frame.

    Outside the hull this is the unit vector from the point to its closest boundary point (at an edge it is the
    edge's inward normal, at a vertex it turns continuously between the two edges' normals). Inside (possible
    in the T-block's notches) it is the inward normal of the closest edge.

    Every per-edge quantity is affine in the query point, so two fused multiply-adds give them all for every point
    and edge at once (the cylinder's 64-gon made the edge-by-edge version the env's costliest term).

    Args:
        hull: CCW vertices in the object frame, (V, 2).
        object_xy: (E, 2). object_yaw: (E,). points: (E, A, 2), world frame.

    Returns:
        Shape: (E, A, 2).
    """
    E, A = points.shape[0], points.shape[1]
    start, edge, left, weights, bias, len2 = _hull_edges(hull)
    cos, sin = torch.cos(object_yaw).unsqueeze(1), torch.sin(object_yaw).unsqueeze(1)  # (E, 1)
    rel = points - object_xy.unsqueeze(1)
    qx, qy = cos * rel[..., 0] + sin * rel[..., 1], cos * rel[..., 1] - sin * rel[..., 0]  # R(-yaw) rel, (E, A)
    q = torch.stack([qx, qy], -1).view(E * A, 2)  # in the object frame
    # per point and edge k, all affine in q: u = (q - s_k).e_k / |e_k|^2, the closest point's place
    # along the edge before clamping; w = |q - s_k|^2 - |q|^2; c = (q - s_k).left_k, >= 0 left of edge k. Float64:
    # ranking by the expanded w cancels digits that float32 lacks at a vertex.
    q64 = q.double()  # elementwise, not a matrix product: BLAS threads would fight the physics threads for cores
    u, w, c = torch.addcmul(bias, q64[:, :1], weights[0]).addcmul_(q64[:, 1:], weights[1]).chunk(3, dim=1)
    t = u.clamp(0.0, 1.0)
    k = torch.addcmul(w, t, (t - 2.0 * u) * len2).argmin(1)  # nearest edge: |q - (s_k + t e_k)|^2 - |q|^2
    gap = start[k] + t.gather(1, k.unsqueeze(1)).float() * edge[k] - q  # from the point to its closest boundary point
    dist = torch.linalg.vector_norm(gap, dim=-1, keepdim=True)
    inside = (c >= 0).all(1, keepdim=True)  # left of (or on) every edge
    n = torch.where(~inside & (dist > 1e-6), gap / dist.clamp_min(1e-6), left[k]).view(E, A, 2)
    nx, ny = n[..., 0], n[..., 1]
    return torch.stack([cos * nx - sin * ny, sin * nx + cos * ny], -1)  # back to the world frame: R(yaw) n


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


def path_progress(env, alpha: float) -> torch.Tensor:
    """alpha * (L_{t-1} - L_t) - L_t, with L the object's remaining path length in m (from its projection onto the
    reference path to the path's end) at the decision's start and now: `subgoal_progress`'s form along the path,
    for policies that have no subgoal (H+L FT); shared."""
    remaining = remaining_length(env.path, env.state.object_xy)
    return _shared(env, _approaching(env.path_remaining_at_decision, remaining, alpha))


def obstacle_proximity(env) -> torch.Tensor:
    """1 / (1 + d), d from the object's footprint to the nearest obstacle's, in m (0 when touching)."""
    return _shared(env, 1.0 / (1.0 + env.object_obstacle_gap.amin(-1).clamp(min=0.0)))
