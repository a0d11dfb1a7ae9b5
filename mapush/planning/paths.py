"""Polylines for the high level: arc-length resampling, the paper's random curved training paths, nearest points.

Every reference path, planned or random, is resampled to the same number of points evenly spaced along its
length (`level.path.points`), so that a batch of envs holds its paths as one (E, P, 2) tensor.
"""

from __future__ import annotations

import numpy as np
import torch

SPLINE_KNOTS = torch.tensor([0.0, 0.25, 0.5, 0.75, 1.0])
DENSE = 256
"""Spline samples before the arc-length resampling."""


def resample(polyline: torch.Tensor, count: int) -> torch.Tensor:
    """`count` points evenly spaced by arc length along polylines (..., M, 2), ends kept: (..., count, 2)."""
    seg = torch.linalg.vector_norm(polyline[..., 1:, :] - polyline[..., :-1, :], dim=-1)  # (..., M-1)
    cum = torch.cat([torch.zeros_like(seg[..., :1]), seg.cumsum(-1)], -1)  # (..., M)
    target = cum[..., -1:] * torch.linspace(0.0, 1.0, count)  # (..., count)
    idx = torch.searchsorted(cum.contiguous(), target.contiguous(), right=True).clamp(1, polyline.shape[-2] - 1)
    lo, hi = cum.gather(-1, idx - 1), cum.gather(-1, idx)
    frac = ((target - lo) / (hi - lo).clamp(min=1e-9)).unsqueeze(-1)
    p0 = polyline.gather(-2, (idx - 1).unsqueeze(-1).expand(*idx.shape, 2))
    p1 = polyline.gather(-2, idx.unsqueeze(-1).expand(*idx.shape, 2))
    return p0 + frac * (p1 - p0)


def _natural_spline_basis(knots: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Matrix B (len(t), len(knots)) with spline(t) = B @ values for the natural cubic spline through the knots."""
    k = knots.double().numpy()
    n = len(k)
    h = np.diff(k)
    # second derivatives m solve A m = R y, with m_0 = m_{n-1} = 0
    A = np.zeros((n, n))
    R = np.zeros((n, n))
    A[0, 0] = A[-1, -1] = 1.0
    for i in range(1, n - 1):
        A[i, i - 1], A[i, i], A[i, i + 1] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        R[i, i - 1], R[i, i], R[i, i + 1] = 6 / h[i - 1], -6 / h[i - 1] - 6 / h[i], 6 / h[i]
    M = np.linalg.solve(A, R)  # second derivatives as a linear map of the values
    tt = t.double().numpy()
    seg = np.clip(np.searchsorted(k, tt, side="right") - 1, 0, n - 2)
    x0, x1, hs = k[seg], k[seg + 1], h[seg]
    a, b = (x1 - tt) / hs, (tt - x0) / hs
    basis = np.zeros((len(tt), n))
    rows = np.arange(len(tt))
    basis[rows, seg] += a
    basis[rows, seg + 1] += b
    basis += ((a**3 - a) * hs**2 / 6)[:, None] * M[seg] + ((b**3 - b) * hs**2 / 6)[:, None] * M[seg + 1]
    return torch.from_numpy(basis).float()


_BASIS = _natural_spline_basis(SPLINE_KNOTS, torch.linspace(0.0, 1.0, DENSE))


def random_curved_paths(gen: torch.Generator, start: torch.Tensor, goal: torch.Tensor, noise: float, count: int):
    """The paper's training paths (paper App. A; docs/fidelity.md), `count` points each.

    A natural cubic spline through start S, Q1, M, Q2 and goal E at t = 0, 1/4, 1/2, 3/4, 1, where
    M = (S + E) / 2 + u1, Q1 = (S + M) / 2 + u2, Q2 = (M + E) / 2 + u3 and each u ~ U[-noise, noise]^2.

    Args:
        start, goal: (n, 2).

    Returns:
        (n, count, 2), evenly spaced by arc length, from start to goal.
    """
    u = (torch.rand(start.shape[0], 3, 2, generator=gen) * 2 - 1) * noise
    mid = (start + goal) / 2 + u[:, 0]
    knots = torch.stack([start, (start + mid) / 2 + u[:, 1], mid, (mid + goal) / 2 + u[:, 2], goal], 1)  # (n, 5, 2)
    dense = _BASIS @ knots  # (n, DENSE, 2)
    return resample(dense, count)


def nearest_index(path: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """Index of the path point (E, P, 2) nearest to each point (E, 2): (E,)."""
    return torch.linalg.vector_norm(path - points.unsqueeze(1), dim=-1).argmin(-1)


def distance_to_path(path: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """Distance from each point (E, 2) to the nearest sampled point of its path (E, P, 2): (E,)."""
    return torch.linalg.vector_norm(path - points.unsqueeze(1), dim=-1).amin(-1)


def remaining_length(path: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """Arc length from each point's projection onto its polyline (E, P, 2) to the polyline's end: (E,). The
    projection is onto the nearest segment, so it moves smoothly as the point does (a potential for shaping)."""
    a, b = path[:, :-1], path[:, 1:]  # segments (E, P - 1, 2)
    seg = b - a
    seg_len = torch.linalg.vector_norm(seg, dim=-1)  # (E, P - 1)
    rel = points.unsqueeze(1) - a
    t = ((rel * seg).sum(-1) / (seg_len**2).clamp(min=1e-12)).clamp(0.0, 1.0)
    gap = torch.linalg.vector_norm(rel - t.unsqueeze(-1) * seg, dim=-1)
    k = gap.argmin(-1, keepdim=True)  # (E, 1): the nearest segment
    after = seg_len.flip(-1).cumsum(-1).flip(-1) - seg_len  # length of the segments after each one
    return ((1 - t.gather(1, k)) * seg_len.gather(1, k) + after.gather(1, k)).squeeze(1)


def length(path: torch.Tensor) -> torch.Tensor:
    """Arc length of polylines (..., P, 2): (...)."""
    return torch.linalg.vector_norm(path[..., 1:, :] - path[..., :-1, :], dim=-1).sum(-1)


def path_spacing(path: torch.Tensor) -> torch.Tensor:
    """Distance between consecutive points of evenly resampled paths (E, P, 2): (E,)."""
    return torch.linalg.vector_norm(path[:, 1] - path[:, 0], dim=-1)
