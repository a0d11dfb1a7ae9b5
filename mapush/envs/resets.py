"""Episode start layouts, sampled for many envs at once (paper App. A; paper-and-original.md 2.3)."""

from __future__ import annotations

import math

import torch

from mapush.errors import BadInput

MAX_REJECTION_ROUNDS = 32
"""Rounds of resampling for envs whose robots spawned too close; the rest get evenly spread angles."""


def ring_capacity(radius: float, min_distance: float) -> int:
    """Most robots that fit on a ring of `radius` with centres at least `min_distance` apart."""
    if min_distance >= 2 * radius:
        return 1
    return math.floor(math.pi / math.asin(min_distance / (2 * radius)) + 1e-9)


def check_agent_count(task_cfg: dict, min_distance: float) -> None:
    """Raise BadInput unless the task's agent count fits its spawn ring."""
    n, cap = task_cfg["num_agents"], ring_capacity(task_cfg["spawn"]["agent_radius"][0], min_distance)
    if not isinstance(n, int) or not 1 <= n <= cap:
        raise BadInput(f"task.num_agents={n} does not fit the {task_cfg['name']} spawn ring; valid: 1 to {cap}")


def uniform(gen: torch.Generator, low: float, high: float, *shape: int) -> torch.Tensor:
    """Uniform samples in [low, high)."""
    return low + (high - low) * torch.rand(*shape, generator=gen)


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
        `friction` (n,).
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
    }
