"""The tracker falls where its Go1 does: in every calibration test with a fall outcome, group by group."""

from __future__ import annotations

import json

import numpy as np
import pytest
from omegaconf import OmegaConf
from paths import REPO

from mapush.calibration import consistency
from mapush.calibration.run import default_config_path

CALIBRATION = REPO / "results" / "calibration" / "calibration.json"


def test_the_committed_calibration_is_consistent_in_every_test_with_a_fall():
    """Recomputed from the committed record's per-trial falls, not read from its verdict."""
    summary = json.loads(CALIBRATION.read_text())
    found = consistency.compare(summary)
    assert found["passed"], "; ".join(consistency.describe(found))
    assert set(found["tests"]) == set(consistency.TESTS)


def test_the_package_tracker_is_the_one_that_calibration_wrote():
    """The fall model checked above is the tracker's, key by key."""
    summary = json.loads(CALIBRATION.read_text())
    tracker = OmegaConf.to_container(OmegaConf.load(default_config_path()))
    for key, value in summary["written"].items():
        assert tracker[key] == value, key


def test_grades_with_few_trials_are_pooled_with_their_neighbours():
    grades, trials = [1, 2, 3, 4, 5, 6, 7, 8, 9], [6] * 9
    found = consistency.groups(grades, trials, [0] * 9, [0] * 9)
    assert [g["grades"] for g in found] == [[1, 2, 3, 4], [5, 6, 7, 8, 9]]  # the short remainder joins the last
    assert [g["trials"] for g in found] == [24, 30]


def test_a_tracker_that_falls_where_its_go1_stands_fails_and_says_where():
    summary = {
        "push": {"drag_n": [10.0] * 24, "fell": [False] * 24, "tracker_fall_p": [0.0] * 24},
        "falls": {"load_n": [50.0] * 24, "fell": [True] * 24, "tracker_fall_p": [0.95] * 24},
        "squeezes": {
            "envs": 24,
            "layout": ["alone"],
            "first_fell": [0.0],
            "fell": [0.0],
            "tracker_first_fell": [0.0],
            "tracker_fell": [0.0],
        },
        "shoves": {"envs": 24, "pair_speed": [0.4, 0.5], "fell": [0.0, 0.0], "tracker_fall_p": [0.21, 0.67]},
    }
    found = consistency.compare(summary)
    assert not found["passed"] and found["failed"] == ["shoves"]
    lines = consistency.describe(found)
    assert len(lines) == 2 and "shoves at 0.5" in lines[1] and "67%" in lines[1] and "0% of 24" in lines[1]
    summary["shoves"]["tracker_fall_p"] = [0.0, 0.05]
    assert consistency.compare(summary)["passed"]
    del summary["squeezes"]  # a test without the tracker's side fails too
    assert consistency.compare(summary)["failed"] == ["squeezes"]


def test_the_expected_fall_is_the_hazard_the_tracker_accumulates():
    """`contact_hazard` rebuilds the hazard from recorded loads as the tracker's own `load_rate` integrates it."""
    from mapush.lowlevel.tracker import Tracker

    model = {"load_n": 50.0, "width_n": 2.0, "window_s": 4.0, "filter_s": 0.2}
    tracker = Tracker({"size": [0.65, 0.28, 0.3], "mass": 12.0, "fall": model})
    load = np.linspace(30.0, 70.0, 200).reshape(2, 100, 1)
    dt = 0.02
    direct = (tracker.load_rate(load) * dt).sum(1)
    rebuilt = consistency.contact_hazard(load, np.zeros_like(load), dt, [50.0], 2.0, 4.0)[0]
    np.testing.assert_allclose(rebuilt, direct, rtol=1e-9)


@pytest.mark.slow
def test_the_contact_midpoint_is_the_lowest_that_keeps_the_tracker_up_where_a_go1_stood():
    """Against a Go1 that never fell in any contact test, the fitted midpoint keeps the tracker's expected falls
    within the tolerance in every group, and one a few newtons lower does not."""
    from mapush.calibration import capacity
    from mapush.calibration.squeeze import LAYOUTS, PAIR_SPEEDS

    model = {"load_n": 0.0, "width_n": 1.0, **capacity.FALL_TIMES, "held_n": 20.0, "held_width_n": 1.0}
    tracker = ["lowlevel=tracker", "lowlevel.force_cap=planar", *capacity.fall_overrides(model)]
    measured = consistency.measure_tracker(tracker, repeats=1, seed=0, envs=2)
    drag = np.repeat(capacity.DRAG_GRID, 1)
    go1 = {
        "push_drag": drag,
        "push_fell": np.zeros(len(drag), dtype=bool),
        "squeeze_first": np.zeros(len(LAYOUTS)),
        "squeeze_any": np.zeros(len(LAYOUTS)),
        "shove_fell": np.zeros(len(PAIR_SPEEDS)),
    }
    midpoint = consistency.fit_contact_midpoint(measured, go1, model)
    assert midpoint is not None and midpoint > model["held_n"]

    def worst(load_n: float) -> float:
        probes = [measured["push"], *measured["squeezes"], measured["shoves"]]
        return max(
            float(consistency.expected_falls(consistency.contact_hazard(
                p.load, p.other_rate, p.dt, [load_n], model["width_n"], model["window_s"])[0])["any"].max())
            for p in probes
        )  # fmt: skip

    assert worst(midpoint - 3.0) > consistency.TOLERANCE
