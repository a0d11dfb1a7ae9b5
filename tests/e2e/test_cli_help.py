"""What `mapush --help` and the experiment commands' help say: the levels, and the experiments as they are now."""

from __future__ import annotations

import re
import shutil

import pytest
from paths import REPO

EXPERIMENTS = REPO / "mapush" / "conf" / "experiment"


@pytest.fixture
def wide(monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")  # rich wraps help at the terminal's width: one line a sentence here


def test_the_top_help_says_what_each_level_is_and_which_command_trains_it(cli, wide):
    proc = cli("--help")
    assert proc.returncode == 0, proc.stderr
    lines = {m.group(1): m.group(0) for m in re.finditer(r"\b(locomotion|mid|high): .*", proc.stdout)}
    assert set(lines) == {"locomotion", "mid", "high"}, proc.stdout
    assert "Go1" in lines["locomotion"] and "level=locomotion" in lines["locomotion"]
    assert "push" in lines["mid"] and "subgoal" in lines["mid"]
    assert "planned path" in lines["high"] and "level=high" in lines["high"]
    assert all("mapush train" in line for line in lines.values())


def test_the_sweep_help_names_every_experiment_file(cli, wide):
    proc = cli("sweep", "--help")
    assert proc.returncode == 0, proc.stderr
    listed = re.search(r"experiment=([\w|]+)", proc.stdout).group(1).split("|")
    assert sorted(listed) == sorted(p.stem for p in EXPERIMENTS.glob("*.yaml")), proc.stdout
    assert "budget=" in proc.stdout and "smoke" in proc.stdout


def test_a_new_experiment_file_is_in_the_help_without_code_changes(cli, wide, monkeypatch, tmp_path):
    conf = shutil.copytree(REPO / "mapush" / "conf", tmp_path / "conf")
    shutil.copyfile(conf / "experiment" / "scale.yaml", conf / "experiment" / "crowd.yaml")
    monkeypatch.setenv("MAPUSH_CONF_DIR", str(conf))
    proc = cli("sweep", "--help")
    assert proc.returncode == 0, proc.stderr
    assert "crowd" in re.search(r"experiment=([\w|]+)", proc.stdout).group(1).split("|"), proc.stdout
