"""`mapush calibrate`'s fits against known truths, and the command end to end on a robot whose answers are known:
the tracker itself."""

from __future__ import annotations

import json
import re
import shlex
import shutil

import numpy as np
import pytest
from omegaconf import OmegaConf
from paths import REPO

from mapush.calibration import capacity
from mapush.calibration.lags import LAG_GRID, STEADY_MIN, fit_lag, steady_fractions, step_commands
from mapush.calibration.run import default_config_path
from mapush.calibration.tracker_option import use_line
from mapush.config import compose_config, to_plain


def test_the_lag_fit_recovers_a_known_first_order_response():
    dt, lag = 0.02, 0.3
    t = (np.arange(100) + 1) * dt
    commanded = np.array([0.25, 0.5])
    response = commanded[:, None] * (1 - np.exp(-t / lag))
    nearest = LAG_GRID[np.abs(LAG_GRID - lag).argmin()]
    assert fit_lag(response, commanded, dt) == pytest.approx(nearest)


def test_a_robot_that_does_not_hold_a_command_is_told_apart_from_a_first_order_lag():
    dt, lag = 0.02, 0.2
    t = (np.arange(150) + 1) * dt
    commands = step_commands([0.25, 0.5])  # (6, 3): two steps along each axis
    size = commands.max(1, keepdims=True)  # each row's one nonzero command
    follows = (size * (1 - np.exp(-t / lag)))[:, :, None] * (commands != 0)[:, None, :]  # (6, T, 3)
    assert all(share == pytest.approx(1.0, abs=0.01) for share in steady_fractions(follows, commands, 25).values())
    fades = follows.copy()
    fades[4:, :, 2] *= np.exp(-t / 1.0)[None, :]  # turns at first, then stops turning (the force-tuned Go1, 11-25)
    shares = steady_fractions(fades, commands, 25)
    assert shares["yaw_rate"] < STEADY_MIN and shares["vx"] == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("true_capacity", [17.0, 33.0, 61.0])
def test_the_capacity_fit_recovers_a_known_stall_force(true_capacity):
    """A robot whose object speed falls linearly from 0.4 m/s to 0 at its capacity, measured with noise."""
    rng = np.random.default_rng(0)
    drag = np.repeat(capacity.DRAG_GRID, 6)
    speed = np.clip(0.4 * (1 - drag / true_capacity), 0, None) + rng.normal(0, 0.01, drag.shape)
    speed = np.clip(speed, 0, None)
    assert capacity.fit_capacity(drag, speed) == pytest.approx(true_capacity * (1 - 0.05 / 0.4), abs=2.5)


def test_a_capacity_beyond_the_sweep_is_none():
    drag = np.repeat(capacity.DRAG_GRID, 2)
    assert capacity.fit_capacity(drag, np.full(drag.shape, 0.3)) is None


@pytest.mark.parametrize(("load_n", "width_n"), [(45.0, 4.0), (80.0, 10.0)])
def test_the_fall_fit_recovers_a_known_curve_from_synthetic_falls(load_n, width_n):
    rng = np.random.default_rng(1)
    load = np.repeat(capacity.LOAD_GRID, 200)
    fell = rng.random(load.shape) < capacity.fall_probability(load, load_n, width_n)
    curve = capacity.fit_fall_curve(load, fell)
    assert curve["load_n"] == pytest.approx(load_n, abs=2.0)
    assert curve["width_n"] == pytest.approx(width_n, rel=0.3)


def test_a_lag_at_the_fit_grids_end_is_reported_as_a_bound():
    from mapush.calibration.lags import at_grid_bound

    t = np.arange(1, 151) * 0.02
    instant = np.ones((4, t.size))  # at its commanded rate from the first sample: quicker than the grid resolves
    lag = fit_lag(instant, np.ones(4), 0.02)
    assert (
        lag == LAG_GRID[0]
        and at_grid_bound(lag) == "0.02 s is the fit grid's bound: the robot responds at least this quickly"
    )
    slow = 1.0 - np.exp(-t[None, :] / 0.3).repeat(4, 0)
    assert at_grid_bound(fit_lag(slow, np.ones(4), 0.02)) is None


def test_no_fall_gives_no_curve():
    load = np.repeat(capacity.LOAD_GRID, 3)
    assert capacity.fit_fall_curve(load, np.zeros(load.shape, dtype=bool)) is None


@pytest.mark.slow
def test_calibrating_the_tracker_against_itself_recovers_its_lag_and_capacity(cli, tmp_path, monkeypatch):
    """The tracker pushes at most min(max_force, mass / lag x 0.5 m/s) at a standstill: the capacity measured is
    that, less the stall speed's share; without a fall model it cannot fall, so no fall curve is written, and a
    tracker whose base cannot fall either (a conf tree whose tracker has `fall: null`) is consistent with it and
    written as `lowlevel=tracker_calibrated` beside the record."""
    conf = shutil.copytree(default_config_path().parents[1], tmp_path / "conf")
    base = conf / "lowlevel" / "tracker.yaml"
    base.write_text(re.sub(r"^fall:.*$", "fall: null", base.read_text(), flags=re.M))
    monkeypatch.setenv("MAPUSH_CONF_DIR", str(conf))
    proc = cli("calibrate", "lowlevel=tracker", "lowlevel.fall=null", "--duration", "1.5", "--settle", "0",
               "--repeats", "1", "--out", tmp_path / "cal")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    tracker = OmegaConf.load(default_config_path())
    assert summary["fitted"]["lag"] == pytest.approx(tracker.lag, rel=0.1)
    assert summary["fitted"]["yaw_lag"] == pytest.approx(tracker.yaw_lag, rel=0.1)
    stall = min(tracker.max_force, tracker.mass / tracker.lag * capacity.PUSH_SPEED)
    assert summary["capacity_n"] == pytest.approx(stall * (1 - capacity.STALL_SPEED / capacity.PUSH_SPEED), rel=0.1)
    assert summary["fall_curve"] is None and [w.split(":")[0] for w in summary["warnings"]] == ["fall"]
    assert summary["consistency"]["passed"]
    written = tmp_path / "cal" / "lowlevel" / "tracker_calibrated.yaml"
    assert summary["tracker_config"] == str(written)
    assert OmegaConf.load(written).max_force == pytest.approx(summary["capacity_n"], abs=0.05)
    assert OmegaConf.load(written).fall is None and "calibrated against tracker" in written.read_text()
    assert (tmp_path / "cal" / "calibration.png").stat().st_size > 0


@pytest.mark.slow
def test_calibrate_writes_a_tracker_option_the_printed_line_composes_and_leaves_the_package_as_it_was(cli, tmp_path):
    conf = default_config_path().parents[1]
    before = {p: p.read_bytes() for p in sorted(conf.rglob("*")) if p.is_file()}
    proc = cli("calibrate", "lowlevel=tracker", "--duration", "0.5", "--settle", "0", "--repeats", "1",
               "--out", "cal", "--name", "mine")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert {p: p.read_bytes() for p in sorted(conf.rglob("*")) if p.is_file()} == before  # byte for byte
    summary = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert tmp_path / summary["tracker_config"] == tmp_path / "cal" / "lowlevel" / "mine.yaml"
    assert summary["written"], summary["warnings"]
    lines = [line for line in proc.stdout.splitlines() if line.startswith("use it: ")]
    assert lines == [use_line("mine", tmp_path / "cal")], proc.stdout
    command = shlex.split(lines[0].removeprefix("use it: "))
    assert command[:3] == ["mapush", "train", "lowlevel=mine"]
    lowlevel = to_plain(compose_config(command[2:]))["lowlevel"]  # from another working dir than calibrate's
    assert lowlevel["name"] == "mine" and lowlevel["backend"] == "tracker"
    assert {key: lowlevel[key] for key in summary["written"]} == summary["written"]


def test_two_seeds_measure_the_tracker_alike(tmp_path):
    """The repeatability target: two seeds' capacities within 10 % (here the robot is the tracker)."""
    a, b = (capacity.push_sweep(["lowlevel=tracker"], 2, seed) for seed in (0, 1))
    ca, cb = capacity.fit_capacity(a["drag"], a["speed"]), capacity.fit_capacity(b["drag"], b["speed"])
    assert abs(ca - cb) <= 0.1 * max(ca, cb)


def test_a_bad_repeat_count_is_one_line(cli):
    proc = cli("calibrate", "--repeats", "0")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0 and "--repeats 0" in proc.stderr


@pytest.mark.parametrize("gain", [60.0, 110.0])
def test_the_push_gain_fit_recovers_a_known_force_speed_line(gain):
    """A robot that pushes drag = gain x (0.5 m/s - speed) until it stalls, measured with noise."""
    rng = np.random.default_rng(2)
    drag = np.repeat(capacity.DRAG_GRID, 6)
    speed = np.clip(capacity.PUSH_SPEED - drag / gain + rng.normal(0, 0.01, drag.shape), 0, None)
    assert capacity.fit_push_gain(drag, speed) == pytest.approx(gain, rel=0.05)


def test_a_robot_that_moves_nothing_has_no_push_gain():
    drag = np.repeat(capacity.DRAG_GRID, 2)
    assert capacity.fit_push_gain(drag, np.zeros(drag.shape)) is None


def test_the_shipped_tracker_falls_pushing_no_more_often_than_the_go1_it_was_calibrated_on():
    """The committed calibration's Go1 push sweep against the tracker of conf/lowlevel/tracker.yaml, same starts."""
    measured = json.loads((REPO / "results" / "calibration" / "calibration.json").read_text())
    sweep = capacity.push_sweep(["lowlevel=tracker"], measured["repeats"], measured["seed"])
    assert sweep["fell"].mean() <= np.mean(measured["push"]["fell"])
    speeds = np.array(measured["push"]["object_speed"])
    assert np.abs(np.median(sweep["speed"]) - np.median(speeds)) < 0.05  # it pushes as fast as the Go1 did


def test_the_reversal_sweep_reverses_at_the_asked_rates_and_a_free_tracker_never_falls():
    from mapush.calibration.reversals import reversal_sweep

    found = reversal_sweep(["lowlevel=tracker", "sim.nthread=1"], envs=16, seconds=4.0, seed=0, rates=(0.0, 5.0))
    assert list(found["rate_hz"]) == [0.0, 5.0]
    assert found["reversals"][0] == 0.0 and found["reversals"][1] == pytest.approx(5.0, rel=0.1)  # 960 draws
    assert list(found["fell"]) == [0.0, 0.0]  # the tracker falls only under contact loads (its `fall` model)
