"""`debug=smoke` on a sweep: a small sweep, at the experiment's smoke budget, not the quick one."""

from __future__ import annotations

from mapush.experiments.sweep_axes import sweep_overrides


def test_debug_smoke_without_a_budget_sweeps_at_the_smoke_budget():
    alone = sweep_overrides(["method=sa", "task=cuboid", "debug=smoke"])
    both = sweep_overrides(["method=sa", "task=cuboid", "budget=smoke", "debug=smoke"])
    assert sorted(alone) == sorted(both)
    assert "budget=smoke" in alone and "seed=0" in alone  # the smoke budget's one seed, not the quick budget's two
    listed = sweep_overrides(["method=sa", "task=cuboid", "overrides=['debug=smoke']"])
    assert "budget=smoke" in listed


def test_a_budget_given_beside_debug_smoke_is_kept():
    given = sweep_overrides(["method=sa", "task=cuboid", "budget=quick", "debug=smoke"])
    assert "budget=quick" in given and "budget=smoke" not in given
