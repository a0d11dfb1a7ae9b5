"""The calibrated tracker as a `lowlevel=` option of its own (`mapush/calibration/tracker_option.py`): written into
calibrate's output dir from the package's tracker as data, and composed by the one line calibrate prints; the
package's config is never written, and the flag that rewrote a config in place is refused."""

from __future__ import annotations

import shlex

import pytest
from omegaconf import OmegaConf

from mapush.calibration.tracker_option import check_name, default_config_path, use_line, write_tracker_option
from mapush.config import compose_config, to_plain
from mapush.errors import BadInput

FITTED = {"lag": 0.2345, "yaw_lag": 0.07, "max_force": 41.5, "fall": {"load_n": 70.1, "width_n": 2.5, "window_s": 4,
          "filter_s": 0.2, "held_n": 50.25, "held_width_n": 2.5}}  # fmt: skip


@pytest.mark.parametrize("where", ["cal", "a dir, with [odd] 'characters'"])
def test_the_printed_line_composes_the_fitted_tracker(tmp_path, where):
    package = default_config_path().read_bytes()
    out = tmp_path / where
    path = write_tracker_option(out, "mine", FITTED, "go1, policy shipped:go1")
    assert path == out / "lowlevel" / "mine.yaml" and default_config_path().read_bytes() == package
    command = shlex.split(use_line("mine", out).removeprefix("use it: "))
    assert command[:3] == ["mapush", "train", "lowlevel=mine"]
    lowlevel = to_plain(compose_config(command[2:]))["lowlevel"]
    assert {key: lowlevel[key] for key in FITTED} == FITTED
    shipped = OmegaConf.to_container(OmegaConf.load(default_config_path()))
    kept = {k: v for k, v in shipped.items() if k not in (*FITTED, "name")}
    assert {k: lowlevel[k] for k in kept} == kept  # every other key the package's
    assert lowlevel["name"] == "mine" and lowlevel["backend"] == "tracker"
    assert "calibrated against go1, policy shipped:go1" in path.read_text()


def test_a_name_the_package_ships_or_no_option_can_carry_is_refused():
    with pytest.raises(BadInput, match=r"--name tracker: mapush ships lowlevel=tracker, .*valid: another name"):
        check_name("tracker")
    with pytest.raises(BadInput, match=r"valid: letters, digits, - and _"):
        check_name("my/tracker")
    check_name("tracker_calibrated")


def test_the_flag_that_rewrote_a_config_in_place_is_refused_in_one_line(cli):
    proc = cli("calibrate", "--config", default_config_path())
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0, proc.stderr
    assert "valid: --name NAME" in proc.stderr and "hydra.searchpath=[file://OUT]" in proc.stderr


def test_a_shipped_name_is_refused_before_anything_is_measured(cli, tmp_path):
    proc = cli("calibrate", "--name", "go1", "--out", tmp_path / "cal")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0, proc.stderr
    assert "--name go1: mapush ships lowlevel=go1" in proc.stderr
