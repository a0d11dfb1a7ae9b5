"""Planning: obstacle geometry, random curved paths, obstacle placement, OMPL plans, `mapush plan`."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import torch

from mapush.commands.plan import random_map
from mapush.envs.resets import goal_clearance, sample_high_layout, sample_obstacles, start_clearance, train_corridor
from mapush.errors import BadInput
from mapush.planning.geometry import corners, point_distance, polygon_gap
from mapush.planning.paths import length, random_curved_paths, resample
from mapush.planning.planner import ObjectPlanner

PLANNER = {"name": "RRTConnect", "max_checks": 50_000, "time_limit_s": 1.0, "range_m": 2.0, "margin_m": 0.1,
           "resolution_m": 0.05, "simplify": True}  # fmt: skip


@pytest.fixture
def high_cfg(cfg_for):
    return cfg_for("level=high")


def test_point_distance_to_a_rotated_square_by_hand():
    square = torch.tensor([[0.0, 0.0, math.pi / 4, 1.0, 1.0]])  # a diamond with corners at +-0.707 on the axes
    points = torch.tensor([[2.0, 0.0], [0.0, 0.0], [1.0, 1.0]])
    d = point_distance(points, square)[:, 0]
    assert d[0].item() == pytest.approx(2.0 - math.sqrt(0.5), abs=1e-5)  # to the corner on the x axis
    assert d[1].item() == 0.0  # inside
    assert d[2].item() == pytest.approx(math.sqrt(2.0) - 0.5, abs=1e-5)  # to the middle of an edge


def test_polygon_gap_by_hand():
    a = corners(torch.tensor([0.0, 0.0, 0.0, 1.0, 1.0]))
    apart = corners(torch.tensor([2.0, 0.0, 0.0, 1.0, 1.0]))
    overlapping = corners(torch.tensor([0.8, 0.3, 0.3, 1.0, 1.0]))
    assert polygon_gap(a, apart).item() == pytest.approx(1.0, abs=1e-6)
    assert polygon_gap(a, overlapping).item() < 0


def test_random_curved_paths_run_from_start_to_goal_evenly_spaced():
    gen = torch.Generator().manual_seed(0)
    start, goal = torch.tensor([[-8.0, 0.0], [-8.0, 3.0]]), torch.tensor([[8.0, 2.0], [8.0, -3.0]])
    paths = random_curved_paths(gen, start, goal, noise=1.0, count=32)
    assert paths.shape == (2, 32, 2)
    assert torch.allclose(paths[:, 0], start, atol=1e-5)
    assert torch.allclose(paths[:, -1], goal, atol=1e-5)
    steps = torch.linalg.vector_norm(paths[:, 1:] - paths[:, :-1], dim=-1)
    assert (steps.std(-1) / steps.mean(-1)).max().item() < 0.01
    straight = torch.linalg.vector_norm(goal - start, dim=-1)
    assert (length(paths) >= straight - 1e-4).all()
    assert (length(paths) < straight * 1.3).all()  # curved, not wild
    other = random_curved_paths(torch.Generator().manual_seed(1), start, goal, noise=1.0, count=32)
    assert not torch.allclose(paths, other)


def test_resample_keeps_ends_and_spacing():
    corner = torch.tensor([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    out = resample(corner, 5)
    assert torch.allclose(out, torch.tensor([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]]))


@pytest.mark.parametrize("training,clear_path", [(True, True), (True, False), (False, True)])
def test_obstacles_never_overlap_the_start_the_goal_or_each_other(high_cfg, training, clear_path):
    high_cfg = copy.deepcopy(high_cfg)
    high_cfg["level"]["obstacles"]["train_clear_path"] = clear_path
    gen = torch.Generator().manual_seed(0)
    n = 200
    layout = sample_high_layout(gen, n, high_cfg)
    start, goal = layout["object_xy"], layout["target_xy"]
    assert (torch.linalg.vector_norm(goal - start, dim=-1) >= 10.0).all()
    path = random_curved_paths(gen, start, goal, 1.0, 32) if training else None
    obstacles = sample_obstacles(gen, high_cfg, start, goal, path)
    assert obstacles.shape == (n, high_cfg["level"]["obstacles"]["count"], 5)
    placed = obstacles[..., 0].abs() < 100
    assert placed.float().mean() > 0.9
    half_diag = math.sqrt(2) / 2
    centres = obstacles[..., :2]
    d_start = torch.linalg.vector_norm(centres - start.unsqueeze(1), dim=-1)
    d_goal = torch.linalg.vector_norm(centres - goal.unsqueeze(1), dim=-1)
    assert (d_start[placed] >= start_clearance(high_cfg) + half_diag - 1e-5).all()
    assert (d_goal[placed] >= goal_clearance(high_cfg) + half_diag - 1e-5).all()
    k = obstacles.shape[1]
    pair = torch.linalg.vector_norm(centres.unsqueeze(2) - centres.unsqueeze(1), dim=-1) + torch.eye(k) * 1e9
    assert (pair >= 2 * half_diag).all()  # footprints never overlap
    if training:
        near = point_distance(path, torch.cat([centres, torch.zeros(n, k, 3)], -1)).amin(1)  # (n, K)
        if clear_path:  # beside the corridor the planner would keep: footprints clear of it, centres in the strip
            corridor = train_corridor(high_cfg)
            assert corridor == pytest.approx(0.85 + high_cfg["level"]["planner"]["margin_m"], abs=0.01)
            gap = point_distance(resample(path, 512), obstacles).amin(1)
            assert (gap[placed] >= corridor - 0.02).all()
            assert (near[placed] <= corridor + 0.5 + 2.0 + 0.05).all()
        else:  # the paper's 4 m strip around the path, which may cross the obstacles
            assert (near[placed] <= 2.0 + 0.05).all()
            assert (point_distance(path, obstacles).amin(1)[placed] < 0.5).any()


def test_planned_paths_avoid_the_inflated_obstacles_and_have_the_waypoint_count(high_cfg):
    planner = ObjectPlanner(PLANNER, 24.0, 0.85)
    radius = 0.85
    try:
        for seed in range(5):
            start, goal, obstacles = random_map(high_cfg, seed)
            result = planner.plan(start, goal, obstacles, 32)
            assert result.solved and result.valid
            assert result.path.shape == (32, 2)
            assert np.allclose(result.path[0], start, atol=1e-4) and np.linalg.norm(result.path[-1] - goal) <= 0.05
            dense = resample(torch.from_numpy(result.path), 2000)
            clear = point_distance(dense, torch.from_numpy(obstacles).float()).amin().item()
            assert clear >= radius  # the object's disc never touches a true obstacle
            assert 0 < result.planning_time_s < 1.0
    finally:
        planner.close()


WALL = np.array([[0.0, y, 0.0, 1.0, 1.0] for y in np.arange(-11.5, 12.0, 1.0)])
"""A wall from floor to ceiling across the room: no path from x < 0 to x > 0."""


def test_an_unreachable_goal_is_a_planner_failure_after_the_work_budget_not_the_clock():
    planner = ObjectPlanner(PLANNER | {"max_checks": 20_000, "time_limit_s": 60.0}, 24.0, 0.85)
    try:
        result = planner.plan(np.array([-8.0, 0.0]), np.array([8.0, 0.0]), WALL, 32)
        assert not result.solved and not result.valid and result.path is None
        assert 20_000 <= planner.checks < 21_000 and planner.wall_clock_stops == 0
    finally:
        planner.close()


def test_the_wall_clock_safety_net_stops_a_plan_and_is_counted():
    planner = ObjectPlanner(PLANNER | {"max_checks": 10**9, "time_limit_s": 0.05}, 24.0, 0.85)
    try:
        result = planner.plan(np.array([-8.0, 0.0]), np.array([8.0, 0.0]), WALL, 32)
        assert not result.solved and planner.wall_clock_stops == 1
    finally:
        planner.close()


def _plan_in_fresh_process(cfg_file) -> list:
    """The path of map 7 from a planner seeded with 3, in a new process that planned nothing before (OMPL's seed
    generator is process-wide)."""
    script = f"""
import json
from mapush.commands.plan import random_map
from mapush.planning.planner import ObjectPlanner
cfg = json.load(open({str(cfg_file)!r}))
planner = ObjectPlanner(cfg["level"]["planner"], 24.0, 0.85, seed=3)
print(json.dumps(planner.plan(*random_map(cfg, 7), 32).path.tolist()))
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    return json.loads(proc.stdout)


def test_a_seeded_plan_does_not_depend_on_what_planned_before_it_in_the_process(high_cfg, tmp_path):
    # a fresh process against this one, after 5 plans of another planner here (and whatever planned before them)
    cfg_file = tmp_path / "cfg.json"
    cfg_file.write_text(json.dumps(high_cfg))
    other = ObjectPlanner(high_cfg["level"]["planner"], 24.0, 0.85, seed=11)
    for s in range(5):
        other.plan(*random_map(high_cfg, s), 32)
    planner = ObjectPlanner(high_cfg["level"]["planner"], 24.0, 0.85, seed=3)
    try:
        here = planner.plan(*random_map(high_cfg, 7), 32).path.tolist()
    finally:
        other.close()
        planner.close()
    assert _plan_in_fresh_process(cfg_file) == here


def test_unknown_planner_names_the_valid_ones():
    with pytest.raises(BadInput, match=r"unknown planner 'RRTFast'; valid: .*RRTConnect"):
        ObjectPlanner(PLANNER | {"name": "RRTFast"}, 24.0, 0.85)


def test_plan_cli_writes_the_contract_json_and_a_png(cli, tmp_path):
    proc = cli("plan", "--task", "tblock", "--seed", "2", "--json", tmp_path / "p.json", "--png", tmp_path / "p.png")
    assert proc.returncode == 0, proc.stderr
    record = json.loads((tmp_path / "p.json").read_text())
    assert {"start", "goal", "path", "obstacles", "planning_time_s", "valid"} <= set(record)
    assert record["valid"] and len(record["path"]) == 32
    assert all(len(quad) == 4 for quad in record["obstacles"])
    assert "valid" in proc.stdout and " m, " in proc.stdout
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


def test_plan_cli_with_a_bad_task_is_bad_input(cli):
    proc = cli("plan", "--task", "sphere")
    assert proc.returncode == 2
    assert "sphere" in proc.stderr and "cuboid" in proc.stderr


def test_a_seeded_planner_repeats_its_plans(high_cfg):
    start, goal, obstacles = random_map(high_cfg, 2)
    paths = []
    for _ in range(2):
        planner = ObjectPlanner(PLANNER, 24.0, 0.85, seed=7)
        try:
            paths.append([planner.plan(start, goal, obstacles, 32).path for _ in range(2)])
        finally:
            planner.close()
    assert all(p is not None for p in paths[0])
    for first, again in zip(paths[0], paths[1], strict=True):
        assert (first == again).all()  # the same sequence of plans from the same seed
