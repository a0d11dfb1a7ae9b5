"""Object footprints: the convex hull used by the OCB reward and the object's reach on the floor."""

from __future__ import annotations

import numpy as np

CIRCLE_HULL_VERTICES = 64
"""A cylinder's footprint is sampled with this many vertices (max chord error 1.5 m * (1 - cos(pi/64)) = 1.8 mm)."""


def part_footprint(part: dict) -> np.ndarray:
    """Corner points of one object part's footprint in the object frame.

    Returns:
        Shape: (n_points, 2).
    """
    cx, cy = part["pos"]
    if part["type"] == "box":
        hx, hy = part["size"][0] / 2, part["size"][1] / 2
        return np.array([[cx - hx, cy - hy], [cx + hx, cy - hy], [cx + hx, cy + hy], [cx - hx, cy + hy]])
    if part["type"] == "cylinder":
        angles = np.linspace(0.0, 2 * np.pi, CIRCLE_HULL_VERTICES, endpoint=False)
        return np.stack([cx + part["size"][0] * np.cos(angles), cy + part["size"][0] * np.sin(angles)], axis=1)
    raise ValueError(f"unknown part type {part['type']!r}; valid: box, cylinder")


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull of 2-D points (Andrew's monotone chain), without collinear points.

    Returns:
        Shape: (n_vertices, 2), counter-clockwise, starting at the lowest-x (then lowest-y) point.
    """
    pts = sorted(set(map(tuple, np.round(points, 12))))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(seq):
        chain: list = []
        for p in seq:
            while len(chain) >= 2 and cross(chain[-2], chain[-1], p) <= 1e-12:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def object_hull(object_cfg: dict) -> np.ndarray:
    """The OCB hull of an object: the configured polygon, or the true convex hull of its footprint.

    Returns:
        Shape: (n_vertices, 2), counter-clockwise, in the object frame.
    """
    if object_cfg.get("hull") is not None:
        hull = np.asarray(object_cfg["hull"], dtype=float)
        signed_area = 0.5 * np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
        if signed_area <= 0:
            raise ValueError("task.object.hull must list its vertices counter-clockwise")
        return hull
    return convex_hull(np.concatenate([part_footprint(p) for p in object_cfg["parts"]]))


def object_radius(object_cfg: dict) -> float:
    """Largest distance from the object's reference point to its footprint, in m."""
    return float(np.max(np.linalg.norm(np.concatenate([part_footprint(p) for p in object_cfg["parts"]]), axis=1)))
