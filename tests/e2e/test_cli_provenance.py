"""A run's meta.json and its eval.json name the mapush that made them, and `mapush eval` warns of other code."""

from __future__ import annotations

import json

import pytest
import yaml

from mapush.provenance import files_hash, package_version

QUICK = ("--episodes", "1", "--seeds", "0", "log.eval_episodes=0")


def test_meta_json_names_the_version_and_package_hash_and_the_config_does_not(smoke_run):
    meta = json.loads((smoke_run / "meta.json").read_text())
    assert meta["mapush_version"] == package_version() and len(meta["package_hash"]) == 64
    assert "package_hash" not in (smoke_run / "config.yaml").read_text()  # a stage's identity hashes the config
    assert "mapush_version" not in yaml.safe_load((smoke_run / "config.yaml").read_text())


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_eval_records_the_code_and_warns_once_when_the_run_was_made_by_other_code(cli, run_copy):
    meta_path = run_copy / "meta.json"
    meta = json.loads(meta_path.read_text()) | {"package_hash": files_hash()}  # the code as it is now, not cached
    meta_path.write_text(json.dumps(meta))
    proc = cli("eval", run_copy, *QUICK)
    assert proc.returncode == 0, proc.stderr
    assert "package hash" not in proc.stderr
    result = json.loads((run_copy / "eval.json").read_text())
    assert result["mapush_version"] == package_version() and result["package_hash"] == meta["package_hash"]
    meta_path.write_text(json.dumps({**meta, "package_hash": "0" * 64}))
    proc = cli("eval", run_copy, *QUICK)
    assert proc.returncode == 0, proc.stderr  # a warning, not an error
    warnings = [line for line in proc.stderr.splitlines() if "package hash" in line]
    assert len(warnings) == 1 and "000000000000" in warnings[0] and result["package_hash"][:12] in warnings[0]


@pytest.mark.slow  # over 8 s on the idle 2-core machine (10-11 s, 2026-12-07)
def test_a_run_made_before_the_hash_was_recorded_evaluates_without_a_warning(cli, run_copy):
    meta_path = run_copy / "meta.json"
    old = {k: v for k, v in json.loads(meta_path.read_text()).items() if k not in ("mapush_version", "package_hash")}
    meta_path.write_text(json.dumps(old))
    proc = cli("eval", run_copy, *QUICK)
    assert proc.returncode == 0, proc.stderr
    assert "package hash" not in proc.stderr and "warning" not in proc.stderr.lower()
