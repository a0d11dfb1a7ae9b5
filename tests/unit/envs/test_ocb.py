"""The occlusion-based reward (OCB) and the hull normal it uses, checked against values worked out by hand.

Convention: the subgoal lies along +x of the object unless stated; OCB = (inward hull normal at the point nearest
the agent) . (unit vector object -> subgoal): +1 behind the object, 0 beside it, -1 in front of it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.rewards.terms import hull_inward_normal, occlusion_based
from mapush.sim.shapes import CIRCLE_HULL_VERTICES, object_hull

CUBOID = {"parts": [{"type": "box", "size": [1.2, 1.2, 0.5], "pos": [0.0, 0.0], "mass": 4.0}], "hull": None}
TBLOCK = {
    "parts": [
        {"type": "box", "size": [1.0, 0.5, 0.5], "pos": [0.0, 0.0], "mass": 2.0},
        {"type": "box", "size": [0.5, 0.5, 0.5], "pos": [0.0, 0.5], "mass": 1.0},
    ],
    "hull": None,
}
CYLINDER = {"parts": [{"type": "cylinder", "size": [1.5, 0.5], "pos": [0.0, 0.0], "mass": 10.0}], "hull": None}


def ocb(object_cfg: dict, agents, subgoal=(5.0, 0.0), object_xy=(0.0, 0.0), yaw: float = 0.0) -> torch.Tensor:
    """OCB of agents at world points `agents` (A, 2) around one object; Shape: (A,)."""
    robot_xy = torch.tensor([agents], dtype=torch.float32)
    env = stand_in_env(
        hull=torch.tensor(object_hull(object_cfg), dtype=torch.float32),
        object_xy=torch.tensor([object_xy], dtype=torch.float32),
        object_yaw=torch.tensor([yaw], dtype=torch.float32),
        robot_xy=robot_xy,
        subgoal_xy=torch.tensor([subgoal], dtype=torch.float32),
        num_envs=1,
        num_agents=robot_xy.shape[1],
    )
    return occlusion_based(env)[0]


def normal(object_cfg: dict, point, yaw: float = 0.0) -> torch.Tensor:
    """Inward hull normal (world frame) for one query point around an object at the origin."""
    hull = torch.tensor(object_hull(object_cfg), dtype=torch.float32)
    return hull_inward_normal(hull, torch.zeros(1, 2), torch.tensor([yaw]), torch.tensor([[point]]))[0, 0]


# ---------------------------------------------------------------------------------------------------- hulls
def test_cuboid_hull_is_its_square_footprint_counter_clockwise():
    assert object_hull(CUBOID).tolist() == [[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]


def test_tblock_hull_is_the_true_convex_hexagon():
    # bar corners (+-0.5, -0.25), (+-0.5, 0.25) and stem top (+-0.25, 0.75);
    # the original's trapezoid drops (+-0.5, 0.25)
    hull = object_hull(TBLOCK)
    assert hull.tolist() == [[-0.5, -0.25], [0.5, -0.25], [0.5, 0.25], [0.25, 0.75], [-0.25, 0.75], [-0.5, 0.25]]


def test_cylinder_hull_is_a_64_gon_on_the_circle():
    hull = object_hull(CYLINDER)
    assert len(hull) == CIRCLE_HULL_VERTICES == 64
    assert np.linalg.norm(hull, axis=1) == pytest.approx(np.full(64, 1.5))


def test_configured_hull_must_be_counter_clockwise():
    clockwise = {**CUBOID, "hull": [[-0.6, -0.6], [-0.6, 0.6], [0.6, 0.6], [0.6, -0.6]]}
    with pytest.raises(ValueError, match="counter-clockwise"):
        object_hull(clockwise)


# ---------------------------------------------------------------------------------------------------- cuboid
def test_ocb_is_plus_one_behind_the_cuboid():
    assert ocb(CUBOID, [(-1.0, 0.0)]).item() == pytest.approx(1.0)


def test_ocb_is_zero_beside_the_cuboid():
    assert ocb(CUBOID, [(0.0, -1.0), (0.0, 1.0)]).tolist() == pytest.approx([0.0, 0.0], abs=1e-6)


def test_ocb_is_minus_one_in_front_of_the_cuboid():
    assert ocb(CUBOID, [(1.0, 0.0)]).item() == pytest.approx(-1.0)


def test_cuboid_normal_at_a_corner_points_diagonally_from_the_agent_to_the_corner():
    # agent (-1, -1), nearest boundary point the corner (-0.6, -0.6): normal (0.4, 0.4) / |.| = (1, 1) / sqrt2
    assert normal(CUBOID, (-1.0, -1.0)).tolist() == pytest.approx([1 / math.sqrt(2), 1 / math.sqrt(2)])


def test_ocb_off_a_cuboid_corner_is_cos_45_degrees():
    assert ocb(CUBOID, [(-1.0, -1.0)]).item() == pytest.approx(0.70711, abs=1e-5)


def test_ocb_follows_the_subgoal_direction():
    # subgoal straight up (+y): the agent below the cuboid is now behind it, the one left of it beside it
    assert ocb(CUBOID, [(0.0, -1.0), (-1.0, 0.0)], subgoal=(0.0, 4.0)).tolist() == pytest.approx([1.0, 0.0], abs=1e-6)


def test_ocb_is_translation_invariant():
    # the same layout shifted by (3, -2)
    shifted = ocb(CUBOID, [(2.0, -2.0), (3.0, -3.0)], subgoal=(8.0, -2.0), object_xy=(3.0, -2.0))
    assert shifted.tolist() == pytest.approx([1.0, 0.0], abs=1e-6)


# ---------------------------------------------------------------------------------------------------- T-block
def test_ocb_is_plus_one_behind_the_tblock():
    # subgoal along +y (the stem side); agent below the bar's bottom edge y = -0.25
    assert ocb(TBLOCK, [(0.0, -1.0)], subgoal=(0.0, 5.0)).item() == pytest.approx(1.0)


def test_ocb_is_zero_beside_the_tblock():
    # agent right of the bar's side x = 0.5 (y in [-0.25, 0.25])
    assert ocb(TBLOCK, [(1.5, 0.0)], subgoal=(0.0, 5.0)).item() == pytest.approx(0.0, abs=1e-6)


def test_ocb_is_minus_one_in_front_of_the_tblock():
    # agent above the stem's top edge y = 0.75
    assert ocb(TBLOCK, [(0.0, 1.5)], subgoal=(0.0, 5.0)).item() == pytest.approx(-1.0)


def test_tblock_normal_on_the_hull_edge_that_bridges_the_notch():
    # edge (0.5, 0.25) -> (0.25, 0.75), direction (-0.25, 0.5); its inward (left) normal is (-2, -1) / sqrt5.
    # Agent (0.75, 0.75) projects onto it at t = 0.6 -> (0.35, 0.55): gap (-0.4, -0.2) -> (-0.8944, -0.4472).
    assert normal(TBLOCK, (0.75, 0.75)).tolist() == pytest.approx([-2 / math.sqrt(5), -1 / math.sqrt(5)], abs=1e-6)
    assert ocb(TBLOCK, [(0.75, 0.75)], subgoal=(0.0, 5.0)).item() == pytest.approx(-1 / math.sqrt(5), abs=1e-6)


def test_tblock_normal_in_the_notch_is_the_nearest_hull_edge_normal():
    # (0.35, 0.45) is inside the hull (the bridging edge is at x = 0.4 for y = 0.45) but outside the T itself.
    # Nearest edge: the bridging one at 0.1 / sqrt5 = 0.045 m (the bar's side is 0.25 m away): normal (-2, -1)/sqrt5
    assert normal(TBLOCK, (0.35, 0.45)).tolist() == pytest.approx([-2 / math.sqrt(5), -1 / math.sqrt(5)], abs=1e-6)


def test_ocb_of_a_tblock_turned_a_quarter_turn():
    # yaw = pi/2 turns the stem from +y to world -x. With the subgoal at world -x, the agent at world (1, 0) is below
    # the bar in the object frame (0, -1): behind, +1; the agent at world (-1.5, 0) is above the stem: in front, -1.
    values = ocb(TBLOCK, [(1.0, 0.0), (-1.5, 0.0)], subgoal=(-5.0, 0.0), yaw=math.pi / 2)
    assert values.tolist() == pytest.approx([1.0, -1.0], abs=1e-6)


def test_rotated_object_normal_is_rotated_into_the_world_frame():
    # object-frame normal (0, 1) below the bar, turned by yaw = pi/2 -> world (-1, 0)
    assert normal(TBLOCK, (1.0, 0.0), yaw=math.pi / 2).tolist() == pytest.approx([-1.0, 0.0], abs=1e-6)


def test_cuboid_turned_45_degrees_presents_a_corner():
    # yaw = pi/4: a corner points to world -x at (-0.8485, 0); an agent at (-1.5, 0.3) sees that corner:
    # gap (0.6515, -0.3) / 0.7172 = (0.9083, -0.4183) -> OCB toward +x = 0.9083
    assert ocb(CUBOID, [(-1.5, 0.3)], yaw=math.pi / 4).item() == pytest.approx(0.9083, abs=1e-4)


# ---------------------------------------------------------------------------------------------------- cylinder
def test_ocb_is_plus_one_behind_the_cylinder():
    assert ocb(CYLINDER, [(-2.0, 0.0)]).item() == pytest.approx(1.0, abs=1e-3)


def test_ocb_is_zero_beside_the_cylinder():
    assert ocb(CYLINDER, [(0.0, -2.0), (0.0, 2.0)]).tolist() == pytest.approx([0.0, 0.0], abs=1e-3)


def test_ocb_is_minus_one_in_front_of_the_cylinder():
    assert ocb(CYLINDER, [(2.0, 0.0)]).item() == pytest.approx(-1.0, abs=1e-3)


def test_cylinder_normal_stays_within_half_an_edge_angle_of_radial():
    # a 64-gon edge spans 2 pi / 64; its normal is at most pi / 64 = 0.049 rad off the radial direction
    angles = torch.linspace(0.0, 2 * math.pi, 361)[:-1]
    points = torch.stack([2.0 * torch.cos(angles), 2.0 * torch.sin(angles)], -1)
    hull = torch.tensor(object_hull(CYLINDER), dtype=torch.float32)
    normals = hull_inward_normal(hull, torch.zeros(1, 2), torch.zeros(1), points.unsqueeze(0))[0]
    cos_off = (normals * -points / 2.0).sum(-1)
    assert cos_off.min().item() >= math.cos(math.pi / 64) - 1e-5


# ---------------------------------------------------------------------------------------------------- oracle
@pytest.mark.parametrize("object_cfg", [CUBOID, TBLOCK, CYLINDER], ids=["cuboid", "tblock", "cylinder"])
def test_hull_normal_agrees_with_shapely_on_random_poses_and_points(object_cfg):
    """Against shapely (GEOS): outside, the unit vector to the nearest point of the hull's boundary; inside, the
    inward normal of the nearest edge. Inside points with a near-tie between two edges (either is right) are left
    out, and so are points on the boundary, where the gap has no direction."""
    shapely = pytest.importorskip("shapely")
    from shapely.ops import nearest_points

    rng = np.random.default_rng(0)
    hull = object_hull(object_cfg)
    E, A = 200, 3
    object_xy, yaw = rng.uniform(-5, 5, (E, 2)), rng.uniform(-math.pi, math.pi, E)
    points = object_xy[:, None] + rng.normal(0.0, 1.0, (E, A, 2))
    got = hull_inward_normal(
        torch.tensor(hull, dtype=torch.float32),
        torch.tensor(object_xy, dtype=torch.float32),
        torch.tensor(yaw, dtype=torch.float32),
        torch.tensor(points, dtype=torch.float32),
    ).numpy()
    checked = 0
    for e in range(E):
        c, s = math.cos(yaw[e]), math.sin(yaw[e])
        world = hull @ np.array([[c, s], [-s, c]]) + object_xy[e]  # R(yaw) v + b, as row vectors
        polygon = shapely.Polygon(world)
        edges = [shapely.LineString([world[k], world[(k + 1) % len(world)]]) for k in range(len(world))]
        for a in range(A):
            point = shapely.Point(points[e, a])
            if polygon.distance(point) == 0.0 and polygon.exterior.distance(point) > 1e-3:  # inside
                (d0, k), (d1, _) = sorted((edge.distance(point), k) for k, edge in enumerate(edges))[:2]
                if d1 - d0 < 1e-4:
                    continue
                start, end = world[k], world[(k + 1) % len(world)]
                want = np.array([start[1] - end[1], end[0] - start[0]])  # left normal of a CCW edge: inward
            elif polygon.exterior.distance(point) > 1e-3:
                want = np.array(nearest_points(polygon.exterior, point)[0].coords[0]) - points[e, a]
            else:
                continue
            np.testing.assert_allclose(got[e, a], want / np.linalg.norm(want), atol=2e-3, err_msg=f"env {e}, robot {a}")
            checked += 1
    assert checked > 0.9 * E * A
