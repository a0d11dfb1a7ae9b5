"""`mapush stages fingerprint` and `mapush stages rekey` through the real CLI: a missing checkout or run is one line
and exit 2; the fingerprint hashes every level, and a rekey between one checkout and itself finds equal
fingerprints (slow: each rolls every level out)."""

from __future__ import annotations

import json

import pytest
from omegaconf import OmegaConf
from paths import REPO
from stand_ins import assert_bad_input

from mapush.config import compose_config
from mapush.levels import LEVELS


def test_fingerprint_names_a_mid_run_that_is_not_there(cli, tmp_path):
    missing = tmp_path / "nowhere"
    assert_bad_input(cli("stages", "fingerprint", missing), str(missing), "is not a run dir")


def test_rekey_names_a_bad_checkout_or_mid_run(cli, tmp_path):
    missing = tmp_path / "nowhere"
    assert_bad_input(cli("stages", "rekey", missing, missing, "experiment=main"), str(missing), "mapush checkout")
    assert_bad_input(cli("stages", "rekey", REPO, missing, "experiment=main"), str(missing), "is not a run dir")


def test_rekey_needs_the_sweeps_overrides(cli, tmp_path):
    mid_run = tmp_path / "mid_run"  # a run dir as far as its config goes: the check comes before any rollout
    mid_run.mkdir()
    OmegaConf.save(compose_config(["debug=smoke"]), mid_run / "config.yaml")
    assert_bad_input(cli("stages", "rekey", REPO, mid_run), "the sweep's overrides", "experiment=main")


@pytest.mark.slow
def test_fingerprint_hashes_every_level_and_the_mid_variants(cli, smoke_run):
    proc = cli("stages", "fingerprint", smoke_run)
    assert proc.returncode == 0, proc.stderr
    hashes = json.loads(proc.stdout.strip().splitlines()[-1])
    assert set(hashes) == {*LEVELS, "mid/tblock", "mid/cylinder", "mid/one_robot"}
    assert all(len(h) == 16 for h in hashes.values())


@pytest.mark.slow
def test_rekey_from_this_checkout_finds_equal_fingerprints_and_nothing_to_adopt(cli, smoke_run, tmp_path):
    proc = cli("stages", "rekey", REPO, smoke_run, "experiment=main", "method=sa", "task=cuboid",
               f"sweep_root={tmp_path / 'sweeps'}", "archive=null")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1].startswith("0 stages adopted from ")
