"""Episode start layouts, sampled for many envs at once (paper App. A; docs/fidelity.md)."""

from __future__ import annotations

import math

import torch

from mapush.planning.geometry import parked, point_distance
from mapush.planning.paths import resample
from mapush.planning.planner import ObjectPlanner
from mapush.sim.shapes import object_radius

MAX_REJECTION_ROUNDS = 32
"""Rounds of resampling for envs whose robots spawned too close; the rest get evenly spread angles."""

CLEARANCE_SAMPLES = 4
"""Samples per path point where a training obstacle's clearance to its path is checked (about 0.1 m apart)."""


def uniform(gen: torch.Generator, low: float, high: float, *shape: int) -> torch.Tensor:
    """Uniform samples in [low, high)."""
    return low + (high - low) * torch.rand(*shape, generator=gen)


def object_masses(gen: torch.Generator, n: int, obj: dict) -> dict[str, torch.Tensor]:
    """The object's mass of `n` episodes as the layout's `mass` (kg), where the task sets one: `mass_range` drawn
    log-uniformly (training over a range of masses), or `mass` fixed; none (the parts' own masses) otherwise.
    Drawn after every other value of the layout, so that a task without it draws as it always did."""
    span, fixed = obj.get("mass_range"), obj.get("mass")
    if span is not None:
        low, high = math.log(float(span[0])), math.log(float(span[1]))
        return {"mass": torch.exp(uniform(gen, low, high, n))}
    if fixed is not None:
        return {"mass": torch.full((n,), float(fixed))}
    return {}


def sample_ring(
    gen: torch.Generator, n: int, num_agents: int, radius: tuple[float, float], min_distance: float
) -> torch.Tensor:
    """Robot offsets from the object centre on a ring, no two closer than `min_distance`.

    Angles are uniform and independent (as in the original); envs with a too-close pair are resampled, and the
    few left after `MAX_REJECTION_ROUNDS` take evenly spread angles with a random rotation and jitter.

    Returns:
        Shape: (n, num_agents, 2).
    """
    offsets = torch.zeros(n, num_agents, 2)
    todo = torch.arange(n)
    for _ in range(MAX_REJECTION_ROUNDS):
        theta = uniform(gen, 0.0, 2 * math.pi, len(todo), num_agents)
        r = uniform(gen, radius[0], radius[1], len(todo), num_agents)
        offsets[todo] = torch.stack([r * torch.cos(theta), r * torch.sin(theta)], -1)
        pts = offsets[todo]
        d = torch.linalg.vector_norm(pts.unsqueeze(2) - pts.unsqueeze(1), dim=-1) + torch.eye(num_agents) * 1e9
        todo = todo[(d < min_distance).flatten(1).any(1)]
        if len(todo) == 0:
            return offsets
    # evenly spread: the chord at the inner radius is >= min_distance when the jitter stays inside the slack
    slack = 2 * math.pi / num_agents - 2 * math.asin(min(1.0, min_distance / (2 * radius[0])))
    base = uniform(gen, 0.0, 2 * math.pi, len(todo), 1) + torch.arange(num_agents) * 2 * math.pi / num_agents
    theta = base + uniform(gen, -0.5, 0.5, len(todo), num_agents) * max(slack, 0.0) * 0.5
    r = (
        uniform(gen, radius[0], radius[1], len(todo), num_agents)
        if slack > 0
        else torch.full((len(todo), num_agents), radius[0])
    )
    offsets[todo] = torch.stack([r * torch.cos(theta), r * torch.sin(theta)], -1)
    return offsets


def sample_mid_layout(gen: torch.Generator, n: int, task_cfg: dict, min_distance: float) -> dict[str, torch.Tensor]:
    """Start layouts of `n` mid-level episodes.

    Object at the task's fixed start with a uniform yaw; subgoal at r ~ U(subgoal_radius), theta ~ U[0, 2 pi) from
    it; robots on the spawn ring with uniform headings; object friction ~ U(task friction range).

    Returns:
        `object_xy` (n, 2), `object_yaw` (n,), `subgoal_xy` (n, 2), `robot_xy` (n, A, 2), `robot_yaw` (n, A),
        `friction` (n,), and `mass` (n,) where the task sets one (`object_masses`).
    """
    spawn, obj = task_cfg["spawn"], task_cfg["object"]
    start = torch.tensor(obj["start_xy"], dtype=torch.float32).expand(n, 2)
    r = uniform(gen, *spawn["subgoal_radius"], n)
    theta = uniform(gen, 0.0, 2 * math.pi, n)
    subgoal = start + torch.stack([r * torch.cos(theta), r * torch.sin(theta)], -1)
    ring = sample_ring(gen, n, task_cfg["num_agents"], spawn["agent_radius"], min_distance)
    return {
        "object_xy": start.clone(),
        "object_yaw": uniform(gen, 0.0, 2 * math.pi, n),
        "subgoal_xy": subgoal,
        "robot_xy": start.unsqueeze(1) + ring,
        "robot_yaw": uniform(gen, 0.0, 2 * math.pi, n, task_cfg["num_agents"]),
        "friction": uniform(gen, *obj["friction"], n),
    } | object_masses(gen, n, obj)


# ---------------------------------------------------------------------------------------------------------------
# Long-horizon (high-level) layouts


def start_clearance(cfg: dict) -> float:
    """Radius around the object's start that obstacles keep clear of: object, robot ring, a robot, margin."""
    task, level = cfg["task"], cfg["level"]
    robot_reach = max(cfg["lowlevel"]["size"][:2]) / 2
    return (
        object_radius(task["object"]) + task["spawn"]["agent_radius"][1] + robot_reach + level["obstacles"]["clearance"]
    )


def goal_clearance(cfg: dict) -> float:
    """Radius around the final target that obstacles keep clear of: the object resting on it, with margin."""
    level = cfg["level"]
    return level["success_distance"] + object_radius(cfg["task"]["object"]) + level["obstacles"]["clearance"]


def sample_high_layout(gen: torch.Generator, n: int, cfg: dict) -> dict[str, torch.Tensor]:
    """Starts and targets of `n` long-horizon episodes: object in the start area, target in the goal area.

    Returns:
        `object_xy` (n, 2), `object_yaw` (n,), `target_xy` (n, 2), `robot_xy` (n, A, 2), `robot_yaw` (n, A),
        `friction` (n,), `subgoal_xy` (n, 2) (the object's own position: no push until the first decision).
    """
    level, task = cfg["level"], cfg["task"]
    start = _in_area(gen, n, level["start_area"])
    target = _in_area(gen, n, level["goal_area"])
    ring = sample_ring(gen, n, task["num_agents"], task["spawn"]["agent_radius"], level["min_spawn_distance"])
    return {
        "object_xy": start,
        "object_yaw": uniform(gen, 0.0, 2 * math.pi, n),
        "target_xy": target,
        "subgoal_xy": start.clone(),
        "robot_xy": start.unsqueeze(1) + ring,
        "robot_yaw": uniform(gen, 0.0, 2 * math.pi, n, task["num_agents"]),
        "friction": uniform(gen, *task["object"]["friction"], n),
    } | object_masses(gen, n, task["object"])


def _in_area(gen: torch.Generator, n: int, area: dict) -> torch.Tensor:
    return torch.stack([uniform(gen, *area["x"], n), uniform(gen, *area["y"], n)], -1)


def sample_obstacles(
    gen: torch.Generator, cfg: dict, start: torch.Tensor, target: torch.Tensor, path: torch.Tensor | None
) -> torch.Tensor:
    """Obstacle blocks of `n` episodes, (n, K, 5) rows of (x, y, yaw, size x, size y).

    With a `path` (training) the centres lie in a strip of `train_strip_width` around it (paper App. A). With
    `train_clear_path` the strip is split to the two sides of a corridor the path keeps clear, as wide as the one
    an OMPL path keeps at evaluation (`train_corridor`), so training paths look like the planned ones. Without a
    path (evaluation) they are uniform between the start and goal areas, across the span of both areas' y ranges
    widened by `test_margin` on each side. No obstacle overlaps the
    start layout, the target or another obstacle; one that finds no room in `MAX_REJECTION_ROUNDS` draws is parked
    outside the arena (absent).
    """
    level = cfg["level"]
    spec = level["obstacles"]
    n, count = start.shape[0], spec["count"]
    size = torch.tensor(spec["size"][:2], dtype=torch.float32)
    half_diag = float(torch.linalg.vector_norm(size)) / 2
    half_room = cfg["sim"]["arena_size"] / 2 - half_diag - 0.1
    keep_start, keep_goal = start_clearance(cfg) + half_diag, goal_clearance(cfg) + half_diag
    apart = 2 * half_diag + spec["gap"]
    x_lo, x_hi = level["start_area"]["x"][1], level["goal_area"]["x"][0]
    y_lo = max(min(level["start_area"]["y"][0], level["goal_area"]["y"][0]) - spec["test_margin"], -half_room)
    y_hi = min(max(level["start_area"]["y"][1], level["goal_area"]["y"][1]) + spec["test_margin"], half_room)
    rows = parked(n, count, 1.0)
    rows[..., 3:] = size
    corridor = train_corridor(cfg) if path is not None else 0.0
    if corridor:
        dense = resample(path, CLEARANCE_SAMPLES * path.shape[1])
    beside = corridor + min(spec["size"][:2]) / 2 if corridor else 0.0  # the nearest a centre can be to the path
    for k in range(count):
        todo = torch.arange(n)
        for _ in range(MAX_REJECTION_ROUNDS):
            m = len(todo)
            if path is not None:
                centre = _in_strip(gen, path[todo], spec["train_strip_width"], beside)
            else:
                centre = torch.stack([uniform(gen, x_lo, x_hi, m), uniform(gen, y_lo, y_hi, m)], -1)
            ok = (centre.abs() <= half_room).all(-1)
            ok &= torch.linalg.vector_norm(centre - start[todo], dim=-1) >= keep_start
            ok &= torch.linalg.vector_norm(centre - target[todo], dim=-1) >= keep_goal
            if corridor:
                block = torch.cat([centre, uniform(gen, 0.0, math.pi / 2, m).unsqueeze(-1), size.expand(m, 2)], -1)
                ok &= point_distance(dense[todo], block.unsqueeze(1)).amin(1).squeeze(-1) >= corridor
            if k:
                ok &= (torch.linalg.vector_norm(rows[todo, :k, :2] - centre.unsqueeze(1), dim=-1) >= apart).all(-1)
            placed = todo[ok]
            rows[placed, k, :2] = centre[ok]
            rows[placed, k, 2] = block[ok, 2] if corridor else uniform(gen, 0.0, math.pi / 2, len(placed))
            todo = todo[~ok]
            if len(todo) == 0:
                break
    return rows


def train_corridor(cfg: dict) -> float:
    """Half-width (m) of the corridor a training path keeps free of obstacle footprints: what the planner keeps
    around its paths (the object's radius plus `planner.margin_m`) with `train_clear_path`, else 0."""
    level = cfg["level"]
    if not level["obstacles"]["train_clear_path"]:
        return 0.0
    return object_radius(cfg["task"]["object"]) + level["planner"]["margin_m"]


def _in_strip(gen: torch.Generator, path: torch.Tensor, width: float, offset: float = 0.0) -> torch.Tensor:
    """A point beside a random interior point of each path (m, P, 2), across the path's direction: within width / 2
    of it, or with an `offset`, between `offset` and `offset + width / 2` from it on either side."""
    m, points = path.shape[0], path.shape[1]
    idx = torch.randint(1, points - 1, (m,), generator=gen)
    rows = torch.arange(m)
    tangent = path[rows, idx + 1] - path[rows, idx - 1]
    tangent = tangent / torch.linalg.vector_norm(tangent, dim=-1, keepdim=True).clamp(min=1e-9)
    normal = torch.stack([-tangent[:, 1], tangent[:, 0]], -1)
    lateral = uniform(gen, -width / 2, width / 2, m)
    lateral = lateral + torch.sign(lateral) * offset
    return path[rows, idx] + normal * lateral.unsqueeze(-1)


def make_planner(cfg: dict) -> ObjectPlanner:
    """The configured OMPL planner for the config's task and room (the long-horizon maps above), seeded with the
    config's seed. Here, not beside the levels: `mapush plan` builds it without importing the envs and PPO."""
    radius = object_radius(cfg["task"]["object"])
    return ObjectPlanner(cfg["level"]["planner"], cfg["sim"]["arena_size"], radius, seed=int(cfg["seed"]))
