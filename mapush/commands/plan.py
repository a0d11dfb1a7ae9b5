"""`mapush plan`: plan the object's path through one random long-horizon map (or many, for timing), and draw it.

The map is the one evaluation would draw for that seed: start and goal areas of `level=high`, obstacles placed at
random between them. JSON keys (docs/design.md): `start`, `goal`, `path` ([x, y] list), `obstacles`
(each the [x, y] corners of its true footprint), `planning_time_s`, `valid`; plus `solved`, `length_m`, `planner`.
"""

from __future__ import annotations

import statistics
from pathlib import Path

import numpy as np
import torch

from mapush.envs.resets import sample_high_layout, sample_obstacles
from mapush.planning.geometry import corners, present
from mapush.planning.planner import ObjectPlanner, PlanResult
from mapush.sim.shapes import object_radius


def random_map(cfg: dict, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start (2,), goal (2,) and obstacles (K, 5) of the evaluation map of `seed`."""
    gen = torch.Generator().manual_seed(seed)
    layout = sample_high_layout(gen, 1, cfg)
    obstacles = sample_obstacles(gen, cfg, layout["object_xy"], layout["target_xy"], None)
    return layout["object_xy"][0].numpy(), layout["target_xy"][0].numpy(), obstacles[0].numpy()


def plan_map(cfg: dict, seed: int, planner: ObjectPlanner) -> tuple[dict, PlanResult]:
    """Plan the map of `seed`; returns the JSON record and the raw result."""
    start, goal, obstacles = random_map(cfg, seed)
    result = planner.plan(start, goal, obstacles, cfg["level"]["path"]["points"])
    on_map = obstacles[present(obstacles)]
    record = {
        "task": cfg["task"]["name"],
        "seed": seed,
        "planner": cfg["level"]["planner"]["name"],
        "start": start.tolist(),
        "goal": goal.tolist(),
        "path": result.path.tolist() if result.path is not None else [],
        "obstacles": corners(torch.from_numpy(on_map)).tolist(),
        "planning_time_s": result.planning_time_s,
        "solved": result.solved,
        "valid": result.valid,
        "length_m": result.length_m,
    }
    return record, result


def timing(cfg: dict, seed: int, maps: int, planner: ObjectPlanner) -> dict:
    """Plan `maps` maps (seeds seed .. seed + maps - 1); median time, the work (state validity checks) each plan
    took, solved and valid counts, and how many plans the wall-clock safety net stopped."""
    times, checks, solved, valid = [], [], 0, 0
    stops_before = planner.wall_clock_stops
    for k in range(maps):
        _, result = plan_map(cfg, seed + k, planner)
        times.append(result.planning_time_s)
        checks.append(planner.checks)
        solved += result.solved
        valid += result.valid
    return {
        "maps": maps,
        "median_s": statistics.median(times),
        "max_s": max(times),
        "median_checks": statistics.median(checks),
        "max_checks": max(checks),
        "wall_clock_stops": planner.wall_clock_stops - stops_before,
        "solved": solved,
        "valid": valid,
    }


def draw(cfg: dict, record: dict, out: Path) -> Path:
    """The room, the obstacles' true footprints, start, goal and the path, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    half = cfg["sim"]["arena_size"] / 2
    radius = object_radius(cfg["task"]["object"])
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    ax.add_patch(plt.Rectangle((-half, -half), 2 * half, 2 * half, fill=False, lw=2, color="0.3"))
    for quad in record["obstacles"]:
        ax.add_patch(Polygon(quad, closed=True, color="0.35"))
    ax.add_patch(Circle(record["start"], radius, color="tab:orange", alpha=0.6, label="object start"))
    ax.add_patch(
        Circle(record["goal"], cfg["level"]["success_distance"], color="gold", alpha=0.6, label="target (success)")
    )
    if record["path"]:
        path = np.array(record["path"])
        ax.plot(path[:, 0], path[:, 1], "-o", ms=2.5, color="tab:blue", label="planned path")
    state = "valid" if record["valid"] else ("INVALID" if record["solved"] else "NO PATH")
    ax.set_title(
        f"{record['task']}, seed {record['seed']}: {record['planner']}, {state}, "
        f"{record['length_m']:.1f} m, {1000 * record['planning_time_s']:.1f} ms",
        fontsize=10,
    )
    ax.set_xlim(-half - 0.5, half + 0.5)
    ax.set_ylim(-half - 0.5, half + 0.5)
    ax.set_aspect("equal")
    ax.legend(loc="upper left", fontsize=8)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return out
