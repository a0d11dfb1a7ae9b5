"""`mapush probe` through the real CLI: a run that is not there is one line and exit 2, and each probe prints its
figures for the smoke run (slow: each rolls out, or plans, a few episodes)."""

from __future__ import annotations

from pathlib import Path

import pytest
from stand_ins import assert_bad_input

import mapush


@pytest.mark.parametrize("probe", ["commands", "falls", "progress"])
def test_a_probe_of_a_missing_run_names_it(cli, tmp_path, probe):
    missing = tmp_path / "nowhere" / "model_5.pt"
    assert_bad_input(cli("probe", probe, missing), str(missing), "valid: a run dir")


def test_a_probe_of_no_episodes_is_refused(cli):
    assert_bad_input(cli("probe", "paths", "--episodes", "0"), "--episodes 0", "valid: 1 or more")


@pytest.mark.slow
def test_the_command_probe_prints_each_axis_figure(cli, smoke_run):
    proc = cli("probe", "commands", smoke_run, "--episodes", "2")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-4] == f"{smoke_run}: S.R. {lines[-4].split('S.R. ')[1]}" and "over 2 pushes" in lines[-4]
    assert [line.split()[0] for line in lines[-3:]] == ["mean_abs", "saturated", "mean_change"]


@pytest.mark.slow
def test_the_progress_probe_compares_with_the_overrides(cli, smoke_run):
    proc = cli("probe", "progress", smoke_run, "--episodes", "2", "--compare", "sim.nthread=1")
    assert proc.returncode == 0, proc.stderr
    labels = [line.split(":")[0] for line in proc.stdout.splitlines() if not line.startswith(" ")]
    assert labels[-2:] == ["as trained", "sim.nthread=1"]


@pytest.mark.slow
def test_the_path_probe_prints_a_row_per_task(cli):
    proc = cli("probe", "paths", "--tasks", "cuboid", "--episodes", "2", "--", "level.planner.max_checks=20000")
    assert proc.returncode == 0, proc.stderr
    header, row = proc.stdout.strip().splitlines()[-2:]
    assert header.split()[:2] == ["task", "mean"] and row.split()[0] == "cuboid"
    assert float(row.split()[-1]) >= 1.0  # a path is no shorter than the straight line


def test_a_fall_probe_replaying_a_negative_count_is_refused(cli):
    shipped = Path(mapush.__file__).parent / "policies" / "cuboid" / "high"
    assert_bad_input(cli("probe", "falls", shipped, "--replay", "-1"), "--replay -1", "valid: 0 (none) or more")


def test_a_reversal_probe_of_no_robots_is_refused(cli):
    assert_bad_input(cli("probe", "reversals", "--envs", "0"), "--envs 0", "valid: --envs 1 or more")


def test_a_squeeze_probe_of_no_robots_is_refused(cli):
    assert_bad_input(cli("probe", "squeeze", "--envs", "0"), "--envs 0", "valid: --envs 1 or more")


@pytest.mark.slow
def test_the_squeeze_probe_prints_a_row_per_layout(cli):
    from mapush.calibration.squeeze import LAYOUTS, PAIR_SPEEDS

    proc = cli("probe", "squeeze", "--envs", "1", "lowlevel=tracker", "sim.nthread=1")
    assert proc.returncode == 0, proc.stderr
    lines = [line.strip() for line in proc.stdout.strip().splitlines()]
    squeezes = [name for name in LAYOUTS if name != "2 against 1"]
    rows = [next(line for line in lines if line.startswith(f"{name} ")) for name in squeezes]
    assert [row.split()[-2:] for row in rows] == [["0.00", "0.00"]] * len(squeezes)  # squeezed, the tracker stands
    graded = lines[-len(PAIR_SPEEDS) :]
    assert [float(row.split()[0]) for row in graded] == list(PAIR_SPEEDS)
    assert graded[0].split()[-1] == "0.00"  # a slow pair does not drive it back


@pytest.mark.slow
def test_the_fall_probe_lets_episodes_go_on_after_a_fall(cli):
    shipped = Path(mapush.__file__).parent / "policies" / "cuboid" / "high"  # 1 s episodes on Go1s: no one falls
    proc = cli("probe", "falls", shipped, "--episodes", "2", "--go-on", "level.episode_length_s=1", "sim.nthread=1")
    assert proc.returncode == 0, proc.stderr
    first, last = proc.stdout.strip().splitlines()[-2:]
    assert first.startswith("success ") and last.startswith("0 envs with a fall")


def test_a_contact_probe_of_a_negative_speed_is_refused(cli):
    assert_bad_input(cli("probe", "contacts", "--speeds", "0.3,-1"), "--speeds '0.3,-1'", "valid: comma-separated")
