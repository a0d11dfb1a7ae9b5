"""`mapush list` and `mapush --version`: what a newcomer can choose, without reading the config files."""

from __future__ import annotations

from importlib import metadata

from mapush.config import group_options
from mapush.rundir import shipped_names


def test_list_names_every_group_option_and_shipped_policy(cli):
    proc = cli("list")
    assert proc.returncode == 0, proc.stderr
    lines = dict(line.split(":", 1) for line in proc.stdout.splitlines())
    for group in ("task", "level", "lowlevel", "method", "experiment", "launcher"):
        assert set(lines[group].strip().split(", ")) == set(group_options(group))
    assert all(name in lines["shipped"] for name in shipped_names())
    assert "mapush.rewards" in lines["trusted"]


def test_version_is_the_installed_distribution_s(cli):
    proc = cli("--version")
    assert proc.returncode == 0 and proc.stdout.strip() == f"mapush {metadata.version('mapush')}"
