"""Obstacle geometry shared by the sampler, the planner and the high-level env: rotated rectangles in the plane.

An obstacle is a row (cx, cy, yaw, sx, sy): centre, heading and full side lengths, in m and rad. Absent obstacles
(fewer than the maximum count) are parked far outside the arena, so they never matter to distances or contacts.
"""

from __future__ import annotations

import numpy as np
import torch

PARKED = 1000.0
"""x (m) of parked obstacles, far outside any arena."""


def rotate(vectors, angle, inverse: bool = False):
    """Vectors (..., 2) turned counter-clockwise by `angle` rad (`inverse`: clockwise, into a frame at that
    heading). `angle`'s shape is a prefix of the vectors' leading dims, or broadcasts against them; torch or numpy."""
    lib = torch if isinstance(vectors, torch.Tensor) else np
    angle = angle.reshape(tuple(angle.shape) + (1,) * (vectors.ndim - 1 - angle.ndim))
    c, s = lib.cos(angle), lib.sin(angle)
    if inverse:
        s = -s
    x, y = vectors[..., 0], vectors[..., 1]
    return lib.stack([c * x - s * y, s * x + c * y], -1)


def parked(n: int, count: int, size: float) -> torch.Tensor:
    """(n, count, 5) obstacles parked out of the way, 3 m apart."""
    rows = torch.zeros(n, count, 5)
    rows[..., 0] = PARKED + 3.0 * torch.arange(count)
    rows[..., 1] = PARKED
    rows[..., 3:] = size
    return rows


def present(obstacles):
    """Which obstacle rows (..., 5) (tensor or array) are on the map, i.e. not parked."""
    return obstacles[..., 0] < PARKED / 2


def corners(obstacles: torch.Tensor) -> torch.Tensor:
    """Footprint corners, counter-clockwise: (..., 5) -> (..., 4, 2)."""
    hx, hy = obstacles[..., 3] / 2, obstacles[..., 4] / 2
    local = torch.stack(
        [
            torch.stack([-hx, -hy], -1),
            torch.stack([hx, -hy], -1),
            torch.stack([hx, hy], -1),
            torch.stack([-hx, hy], -1),
        ],
        -2,
    )  # (..., 4, 2)
    return rotate(local, obstacles[..., 2]) + obstacles[..., None, :2]


def point_distance(points: torch.Tensor, obstacles: torch.Tensor) -> torch.Tensor:
    """Distance from each point to each obstacle's footprint, 0 inside.

    Args:
        points: (..., P, 2).
        obstacles: (..., K, 5).

    Returns:
        (..., P, K).
    """
    rel = points.unsqueeze(-2) - obstacles[..., None, :, :2]  # (..., P, K, 2)
    local = rotate(rel, obstacles[..., 2].unsqueeze(-2), inverse=True).abs()  # in each obstacle's frame
    local_x = local[..., 0] - obstacles[..., 3].unsqueeze(-2) / 2
    local_y = local[..., 1] - obstacles[..., 4].unsqueeze(-2) / 2
    return torch.linalg.vector_norm(torch.stack([local_x.clamp(min=0), local_y.clamp(min=0)], -1), dim=-1)


def polygon_gap(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Separating-axis gap between convex polygons: > 0 apart (a lower bound of their distance), <= 0 overlapping.

    Args:
        a: (..., N, 2) vertices in order; b: (..., M, 2). Leading dims broadcast.

    Returns:
        (...,) the largest gap over the edge normals of both polygons.
    """
    shape = torch.broadcast_shapes(a.shape[:-2], b.shape[:-2])
    a, b = a.expand(*shape, *a.shape[-2:]), b.expand(*shape, *b.shape[-2:])
    axes = torch.cat([_edge_normals(a), _edge_normals(b)], -2).transpose(-1, -2)  # (..., 2, N + M)
    pa, pb = a @ axes, b @ axes  # projections: (..., N, N + M), (..., M, N + M)
    gap = torch.maximum(pb.amin(-2) - pa.amax(-2), pa.amin(-2) - pb.amax(-2))
    return gap.amax(-1)


def _edge_normals(poly: torch.Tensor) -> torch.Tensor:
    edges = torch.roll(poly, -1, dims=-2) - poly
    normal = torch.stack([edges[..., 1], -edges[..., 0]], -1)
    return normal / torch.linalg.vector_norm(normal, dim=-1, keepdim=True).clamp(min=1e-9)


def rectangles(xy: torch.Tensor, yaw: torch.Tensor, length: float, width: float) -> torch.Tensor:
    """Corners of rectangles of one size at poses xy (..., 2), yaw (...): (..., 4, 2)."""
    rows = torch.cat(
        [xy, yaw.unsqueeze(-1), torch.full_like(yaw, length).unsqueeze(-1), torch.full_like(yaw, width).unsqueeze(-1)],
        -1,
    )
    return corners(rows)


def transform(points: torch.Tensor, xy: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """Body-frame points (P, 2) placed at poses xy (..., 2), yaw (...): (..., P, 2)."""
    return rotate(points, yaw.unsqueeze(-1)) + xy.unsqueeze(-2)


NEAR_M = 0.5
"""Pairs whose bounding discs are further apart than this skip the exact polygon test."""


def near_gaps(
    centres: torch.Tensor, radius: float, shapes: torch.Tensor, obstacles: torch.Tensor, obstacle_corners: torch.Tensor
) -> torch.Tensor:
    """Gaps (E, N, K) between N convex shapes per env and each obstacle: exact (separating axes) for pairs whose
    bounding discs come within `NEAR_M`, the bounding-disc gap (a lower bound, > NEAR_M) for the rest.

    Args:
        centres: (E, N, 2) centres of the shapes' bounding discs of `radius`; shapes: (E, N, V, 2) vertices.
        obstacles: (E, K, 5) rows; obstacle_corners: (E, K, 4, 2).
    """
    obstacle_radius = torch.linalg.vector_norm(obstacles[..., 3:], dim=-1) / 2  # (E, K)
    centre_gap = torch.linalg.vector_norm(centres.unsqueeze(2) - obstacles[:, None, :, :2], dim=-1)
    gaps = centre_gap - radius - obstacle_radius.unsqueeze(1)  # (E, N, K)
    near = (gaps < NEAR_M).nonzero(as_tuple=True)
    if len(near[0]):
        e, n, k = near
        gaps[near] = polygon_gap(shapes[e, n], obstacle_corners[e, k])
    return gaps
