"""Old files read as today's (mapush/migrations.py): every file mapush writes for later names its format_version,
a file from before the key reads as version 0, and one from a newer mapush is one line."""

from __future__ import annotations

import json

import pytest
from omegaconf import OmegaConf
from paths import REPO

from mapush.errors import BadInput
from mapush.experiments import results, stages
from mapush.migrations import FORMAT_VERSION, upgrade


def test_a_file_from_before_the_key_is_upgraded_with_its_content_kept():
    old = {"evals": {"main": {"success_rate": 0.5}}, "stages": {"mid": "runs/x"}}
    assert upgrade(old, "result.json") == {**old, "format_version": FORMAT_VERSION}


def test_a_file_of_a_newer_mapush_is_one_line_naming_its_version():
    with pytest.raises(BadInput, match=rf"format_version {FORMAT_VERSION + 1}, newer") as err:
        upgrade({"format_version": FORMAT_VERSION + 1}, "runs/x/result.json")
    assert "\n" not in str(err.value) and "runs/x/result.json" in str(err.value)


def test_stage_records_are_written_with_their_version_and_old_ones_read(tmp_path):
    stages.write_identity(tmp_path / "new", {"seed": 1}, "abc")
    written = OmegaConf.to_container(OmegaConf.load(tmp_path / "new" / stages.IDENTITY_FILE))
    assert written["format_version"] == FORMAT_VERSION
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / stages.IDENTITY_FILE).write_text("identity: abc\nconfig: {seed: 1}\n")
    assert stages.read_identity(tmp_path / "old" / stages.IDENTITY_FILE) == written


def test_a_result_from_before_the_key_reads_as_today_and_is_written_with_it(tmp_path):
    path = tmp_path / results.RESULT
    path.write_text(json.dumps({"evals": {}, "stages": {"mid": "run"}}))
    result = results.read_result(path)
    assert result == results.JobResult(stages={"mid": "run"}, job_dir=str(tmp_path))
    results.write_result(path, result)
    assert json.loads(path.read_text())["format_version"] == FORMAT_VERSION
    assert results.read_result(path) == result


def test_a_result_with_a_field_this_mapush_does_not_know_is_refused(tmp_path):
    path = tmp_path / results.RESULT
    path.write_text(json.dumps({"evals": {}, "stages": {}, "colour": "red"}))
    with pytest.raises(BadInput, match="unknown fields \\['colour'\\]"):
        results.read_result(path)


def test_the_committed_results_all_read():
    """Every result.json kept in git (results/jobs/) reads with this mapush, and writes back as it was read."""
    found = list((REPO / "results" / "jobs").glob("**/" + results.RESULT))
    assert found
    for path in found:
        record = {k: v for k, v in json.loads(path.read_text()).items() if k != "format_version"}
        assert results.read_result(path).record() == record
