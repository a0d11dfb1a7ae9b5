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


def test_a_low_level_run_saved_before_events_reads_its_disturbances_as_event_params(tmp_path):
    """A run saved with `level.randomize.force_n` and friends (the form before 2026-11-29) loads with each value at
    its event's param, and today's `func` for it; its own values win over today's defaults."""
    from mapush.config import compose_config, load_run_config, to_plain

    saved = to_plain(compose_config(["level=locomotion"]))
    level = saved["level"]
    level.pop("events"), level.pop("eval_events")
    level["randomize"].update(
        push_interval_s=6.0, push_velocity=0.4, force_n=50.0, force_duration_s=1.5, force_interval_s=3.0
    )
    level["randomize"]["teammates"] = {"fraction": 0.5, "count": 3, "gap_m": [0.0, 0.2], "lean_mps": [0.0, 0.7]}
    level.update(eval_push_velocity=0.2, eval_force_n=30.0, eval_load_fraction=1.0)
    OmegaConf.save(OmegaConf.create(saved), tmp_path / "config.yaml")
    events = load_run_config(tmp_path).level.events
    upgraded = OmegaConf.to_container(load_run_config(tmp_path).level)
    assert events.push.params == {"interval_s": 6.0, "velocity_mps": 0.4}
    assert events.lean.params == {"force_n": 50.0, "duration_s": 1.5, "interval_s": 3.0}
    assert events.teammates.params.count == 3 and events.teammates.params.lean_mps == [0.0, 0.7]
    assert events.teammates.params.heading_rad == 0.2  # a param the old run did not save: today's default
    assert events.lean.func == "mapush.envs.locomotion_events:Lean"
    assert upgraded["eval_events"] == {
        "push": {"velocity_mps": 0.2},
        "lean": {"force_n": 30.0},
        "load": {"fraction": 1.0},
        "teammates": {"fraction": 0.0},  # not saved: today's default
    }
    assert set(upgraded["randomize"]) == {"friction", "added_mass", "joint_scale"}
    assert not any(key.startswith("eval_") and key not in ("eval_commands", "eval_events") for key in upgraded)


def test_the_shipped_strong_go1_reads_the_disturbances_it_was_trained_under():
    """The shipped `go1_strong` run saved the old form; its overrides.yaml records what it trained under."""
    from mapush.config import load_run_config
    from mapush.rundir import SHIPPED_LOWLEVEL

    run = SHIPPED_LOWLEVEL / "go1_strong"
    overrides = OmegaConf.load(run / "overrides.yaml")
    assert "level.randomize.force_n=50.0" in overrides and "level.randomize.load.fraction=0.5" in overrides
    events = load_run_config(run).level.events
    assert events.lean.params.force_n == 50.0
    assert events.load.params.fraction == 0.5 and events.teammates.params.fraction == 0.5
    assert list(events.teammates.params.lean_mps) == [0.0, 0.7]


def _funcs(node) -> list[str]:
    """Every term's `func` under a config node."""
    if isinstance(node, dict):
        own = [node["func"]] if isinstance(node.get("func"), str) else []
        return own + [f for value in node.values() for f in _funcs(value)]
    return [f for value in node for f in _funcs(value)] if isinstance(node, list) else []


@pytest.mark.parametrize("policy", ["go1", "go1_strong"])
def test_a_run_saved_as_level_low_loads_as_the_locomotion_level_with_importable_terms(policy):
    """The shipped Go1 policies were trained as `level=low` (mapush/envs/low.py) and ship their config as saved."""
    import importlib

    from mapush.config import load_run_config
    from mapush.levels import LEVELS
    from mapush.rundir import SHIPPED_LOWLEVEL

    saved = OmegaConf.to_container(OmegaConf.load(SHIPPED_LOWLEVEL / policy / "config.yaml"))
    old = [f for f in _funcs(saved) if f.startswith(("mapush.envs.low", "mapush.rewards.locomotion:"))]
    assert saved["level"]["name"] == "low" and old
    loaded = OmegaConf.to_container(load_run_config(SHIPPED_LOWLEVEL / policy))
    assert loaded["level"]["name"] == "locomotion" and loaded["level"]["name"] in LEVELS
    new = [f for f in _funcs(loaded) if f.startswith(("mapush.envs.locomotion", "mapush.rewards.legged:"))]
    assert len(new) >= len(old) and not [f for f in _funcs(loaded) if f in old]
    for func in _funcs(loaded):
        module, _, name = func.partition(":")
        assert hasattr(importlib.import_module(module), name), func


def test_a_config_in_todays_form_is_not_renamed():
    from mapush.config import compose_config
    from mapush.migrations import upgrade_run_config

    today = compose_config(["level=locomotion"])
    assert upgrade_run_config(today) is today
