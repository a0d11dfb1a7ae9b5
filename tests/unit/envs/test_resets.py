"""Episode start layouts: subgoal ring, robot spawn ring, spacing, friction and yaw ranges; the agent-count check."""

from __future__ import annotations

import math

import pytest
import torch

from mapush.envs import resets
from mapush.envs.resets import sample_mid_layout, sample_ring
from mapush.envs.spawn_ring import check_agent_count, ring_capacity
from mapush.errors import BadInput

N = 256  # layouts per test


def pairwise_min(points: torch.Tensor) -> torch.Tensor:
    """Smallest distance between two different robots of each env; points (n, A, 2) -> (n,)."""
    d = torch.linalg.vector_norm(points.unsqueeze(2) - points.unsqueeze(1), dim=-1)
    return (d + torch.eye(points.shape[1]) * 1e9).flatten(1).min(1).values


@pytest.fixture
def layout(cfg_for):
    cfg = cfg_for("task=cuboid")
    return sample_mid_layout(torch.Generator().manual_seed(0), N, cfg["task"], 0.75)


def test_layout_shapes(layout):
    shapes = {k: tuple(v.shape) for k, v in layout.items()}
    assert shapes == {
        "object_xy": (N, 2),
        "object_yaw": (N,),
        "subgoal_xy": (N, 2),
        "robot_xy": (N, 2, 2),
        "robot_yaw": (N, 2),
        "friction": (N,),
    }


def test_object_starts_at_the_task_start(layout):
    assert torch.equal(layout["object_xy"], torch.zeros(N, 2))


def test_subgoal_is_1_5_to_3_m_from_the_object(layout):
    d = torch.linalg.vector_norm(layout["subgoal_xy"] - layout["object_xy"], dim=-1)
    assert d.min().item() >= 1.5 - 1e-5
    assert d.max().item() <= 3.0 + 1e-5


def test_subgoal_direction_covers_all_quadrants(layout):
    rel = layout["subgoal_xy"] - layout["object_xy"]
    quadrants = {(bool(x > 0), bool(y > 0)) for x, y in rel.tolist()}
    assert len(quadrants) == 4


def test_robots_are_on_the_spawn_ring(layout):
    # cuboid ring: 1.2 to 1.3 m from the object centre
    r = torch.linalg.vector_norm(layout["robot_xy"] - layout["object_xy"].unsqueeze(1), dim=-1)
    assert r.min().item() >= 1.2 - 1e-5
    assert r.max().item() <= 1.3 + 1e-5


def test_robots_spawn_at_least_the_min_spawn_distance_apart(layout):
    assert pairwise_min(layout["robot_xy"]).min().item() >= 0.75 - 1e-5


def test_friction_is_drawn_from_the_task_range(layout):
    # cuboid: [0.3, 0.35] (the original's [0.5, 0.6] averaged with the 0.1 floor)
    assert layout["friction"].min().item() >= 0.3
    assert layout["friction"].max().item() <= 0.35


def test_object_yaw_is_in_zero_to_two_pi(layout):
    assert layout["object_yaw"].min().item() >= 0.0
    assert layout["object_yaw"].max().item() < 2 * math.pi


def test_object_yaw_spreads_over_the_circle(layout):
    # 256 uniform draws: each quarter turn holds some
    quarters = set((layout["object_yaw"] // (math.pi / 2)).long().tolist())
    assert quarters == {0, 1, 2, 3}


def test_same_generator_seed_gives_the_same_layout(cfg_for):
    task = cfg_for("task=cuboid")["task"]
    a = sample_mid_layout(torch.Generator().manual_seed(7), 8, task, 0.75)
    b = sample_mid_layout(torch.Generator().manual_seed(7), 8, task, 0.75)
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_ring_capacity_of_the_cuboid_ring_is_nine():
    # chord of 9 robots on r = 1.2: 2 * 1.2 * sin(pi/9) = 0.821 >= 0.75; of 10: 2 * 1.2 * sin(pi/10) = 0.742 < 0.75
    assert ring_capacity(1.2, 0.75) == 9


def test_ring_capacity_counts_the_exact_fit():
    # a hexagon inscribed in r = 1 has side exactly 1
    assert ring_capacity(1.0, 1.0) == 6


def test_ring_capacity_is_one_when_the_ring_is_too_small():
    assert ring_capacity(0.3, 0.75) == 1


@pytest.mark.parametrize("num_agents", [1, 9])
def test_agent_counts_that_fit_the_ring_pass(cfg_for, num_agents):
    """1 and 9 robots fit the cuboid's 1.2 m ring 0.75 m apart (9 is the most: 10 is refused below)."""
    task = cfg_for("task=cuboid")["task"]
    task["num_agents"] = num_agents
    assert ring_capacity(task["spawn"]["agent_radius"][0], 0.75) == 9
    check_agent_count(task, 0.75)  # no BadInput, and their layouts place them all, apart
    layout = sample_mid_layout(torch.Generator().manual_seed(0), 16, task, 0.75)
    assert layout["robot_xy"].shape == (16, num_agents, 2)
    if num_agents > 1:
        assert pairwise_min(layout["robot_xy"]).min().item() >= 0.75 - 1e-5


@pytest.mark.parametrize("num_agents", [0, 10, 40])
def test_agent_counts_that_do_not_fit_raise_bad_input_with_the_valid_range(cfg_for, num_agents):
    task = cfg_for("task=cuboid")["task"]
    task["num_agents"] = num_agents
    with pytest.raises(BadInput, match=rf"task.num_agents={num_agents} .*valid: 1 to 9"):
        check_agent_count(task, 0.75)


def test_many_agents_near_capacity_still_spawn_apart_and_on_the_ring():
    # 9 robots on the 1.2-1.3 m ring almost never pass rejection sampling: the evenly spread fallback places them
    offsets = sample_ring(torch.Generator().manual_seed(1), 64, 9, (1.2, 1.3), 0.75)
    r = torch.linalg.vector_norm(offsets, dim=-1)
    assert pairwise_min(offsets).min().item() >= 0.75 - 1e-5
    assert r.min().item() >= 1.2 - 1e-5
    assert r.max().item() <= 1.3 + 1e-5


def test_fallback_alone_spaces_robots_apart(monkeypatch):
    # no rejection rounds: every env takes evenly spread angles with jitter
    monkeypatch.setattr(resets, "MAX_REJECTION_ROUNDS", 0)
    offsets = sample_ring(torch.Generator().manual_seed(2), 64, 9, (1.2, 1.3), 0.75)
    assert pairwise_min(offsets).min().item() >= 0.75 - 1e-5


def test_fallback_rotates_the_spread_at_random(monkeypatch):
    monkeypatch.setattr(resets, "MAX_REJECTION_ROUNDS", 0)
    offsets = sample_ring(torch.Generator().manual_seed(3), 64, 3, (1.2, 1.3), 0.75)
    first_angle = torch.atan2(offsets[:, 0, 1], offsets[:, 0, 0])
    assert first_angle.std().item() > 0.5


def test_an_object_mass_range_is_drawn_per_episode_and_applied_to_the_simulation():
    import numpy as np

    from mapush.config import compose_config, to_plain
    from mapush.envs.mid import MidPushEnv
    from mapush.sim.scene import OBJECT_BODY

    cfg = to_plain(compose_config(["debug=smoke", "task=cuboid", "num_envs=64", "task.object.mass_range=[2.0,16.0]"]))
    env = MidPushEnv(cfg, num_envs=64)
    env.reset(np.arange(64))
    mass = env.sim.batch.expand("body_mass")[:, env.sim.model.body(OBJECT_BODY).id]
    assert mass.min() >= 2.0 and mass.max() <= 16.0 and mass.max() / mass.min() > 3  # spread over the range
    assert 0.5 < float(np.mean(mass < 8.0)) < 0.85  # log-uniform: 2/3 below 8 kg (uniform: 3/7)
    fixed = to_plain(compose_config(["debug=smoke", "task=cuboid", "num_envs=2", "task.object.mass=8.0"]))
    env = MidPushEnv(fixed, num_envs=2)
    env.reset(np.arange(2))
    assert env.sim.batch.expand("body_mass")[:, env.sim.model.body(OBJECT_BODY).id].tolist() == [8.0, 8.0]
