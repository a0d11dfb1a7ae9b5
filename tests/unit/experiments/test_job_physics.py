"""A job's object and one robot (`job_physics`): read from a stage config, the mass an evaluation ran at, and the
one mass a policy trained at."""

from __future__ import annotations

import pytest

from mapush.experiments.job_physics import ObjectPhysics, evaluated_mass, object_physics, trained_mass
from mapush.experiments.results import JobResult

RANGED = ObjectPhysics(mass_kg=4.0, friction=(0.2, 0.4), mass_range_kg=(2.0, 64.0), robot_capacity_n=50.0)
FIXED = ObjectPhysics(mass_kg=4.0, friction=(0.2, 0.4), robot_capacity_n=50.0)


def _stage(lowlevel: dict, **obj) -> dict:
    parts = [{"mass": 1.5}, {"mass": 2.5}]
    return {"task": {"object": {"friction": [0.2, 0.4], "parts": parts, **obj}}, "lowlevel": lowlevel,
            "level": {"action_scale": [1.0, 1.0, 0.5]}}  # fmt: skip


def test_a_stage_config_gives_the_object_and_one_trackers_push():
    tracker = {"name": "tracker", "max_force": 50.0, "mass": 12.0, "lag": 0.2}
    # the velocity loop stalls at 12 kg / 0.2 s x 1 m/s = 60 N: the 50 N cap holds
    assert object_physics(_stage(tracker), pushes=True) == ObjectPhysics(4.0, (0.2, 0.4), None, 50.0)
    slow = {**tracker, "lag": 0.4}  # 30 N: the loop's stall force is below the cap
    assert object_physics(_stage(slow), pushes=True).robot_capacity_n == pytest.approx(30.0)
    mine = {**tracker, "name": "tracker_calibrated", "backend": "tracker"}  # a calibrated tracker of yours
    assert object_physics(_stage(mine), pushes=True).robot_capacity_n == 50.0
    assert object_physics(_stage({"name": "go1"}), pushes=True).robot_capacity_n is None  # legs: calibrate's
    assert object_physics(_stage(tracker), pushes=False).robot_capacity_n is None  # a stage that does not push
    drawn = object_physics(_stage(tracker, mass=8.0, mass_range=[2.0, 64.0]), pushes=True)
    assert (drawn.mass_kg, drawn.mass_range_kg) == (8.0, (2.0, 64.0))
    assert FIXED.drag_n(10.0) == pytest.approx((10 * 9.81 * 0.2, 10 * 9.81 * 0.4))


@pytest.mark.parametrize(
    ("physics", "overrides", "mass"),
    [
        (FIXED, [], 4.0),
        (RANGED, [], None),  # drawn per episode: no one mass
        (RANGED, ["task.object.mass_range=null", "task.object.mass=8.0"], 8.0),  # the team study's evaluations
        (RANGED, ["task.object.mass=8.0"], None),  # the range still drawn
        (FIXED, ["task.object.mass_range=[2,64]"], None),
        (FIXED, ["task.object.mass=null"], None),  # the parts' own: not held apart
        (FIXED, ["~task.object.mass"], None),
        (FIXED, ["task.object.mass=24"], 24.0),
    ],
)
def test_an_evaluations_mass_is_its_one_mass_or_none(physics, overrides, mass):
    assert evaluated_mass(physics, overrides) == mass


def test_the_mass_a_policy_trained_at_comes_from_its_overrides_where_its_stage_records_are_gone():
    at_8 = ["task.object.mass_range=null", "task.object.mass=8.0"]
    assert trained_mass(JobResult(physics=FIXED)) == 4.0 and trained_mass(JobResult(physics=RANGED)) is None
    assert trained_mass(JobResult(overrides=at_8)) == 8.0  # no stages, so no records: the overrides say
    assert trained_mass(JobResult(overrides=["task.object.mass=8.0"])) is None  # the range still drawn
    assert trained_mass(JobResult()) is None
