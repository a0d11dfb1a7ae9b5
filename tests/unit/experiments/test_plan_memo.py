"""A remembered sweep plan (`plan_memo`) is the plan composing gives, and anything it depends on makes a miss."""

from __future__ import annotations

import json
import shutil

import pytest
from omegaconf import OmegaConf

from mapush.config import CONF_DIR
from mapush.errors import BadInput
from mapush.experiments import plan_memo, sweep_axes
from mapush.experiments.sweep_axes import planned_jobs, sweep_overrides

SMALL = ["method=sa", "task=cuboid", "budget=smoke", "debug=smoke"]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(plan_memo.CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(plan_memo, "_READ", {})
    return tmp_path / "cache" / "plans"


def _as_data(jobs) -> list:
    return [(job.combo, OmegaConf.to_container(job.cfg), job.stages) for job in jobs]


def test_a_remembered_plan_is_the_composed_plan_and_composes_nothing(cache, monkeypatch):
    full = sweep_overrides(SMALL)
    composed = planned_jobs(full)
    assert len(list(cache.glob("*.json"))) == 1
    monkeypatch.setattr(plan_memo, "_READ", {})  # another process: read from the file

    def refuse(*args, **kwargs):
        raise AssertionError("a remembered plan composed a config")

    monkeypatch.setattr(sweep_axes, "compose_config", refuse)
    monkeypatch.setattr(sweep_axes, "planned_stages", refuse)
    remembered = planned_jobs(sweep_overrides(SMALL))  # its check too is remembered
    assert _as_data(remembered) == _as_data(composed)
    assert [s.shape for job in remembered for s in job.stages] == [s.shape for job in composed for s in job.stages]
    with pytest.raises(Exception, match="Key 'nosuch' is not in struct"):
        remembered[0].cfg.nosuch = 1  # as strict as a composed config


def test_another_command_line_or_config_file_is_a_miss(cache, tmp_path, monkeypatch):
    full = sweep_overrides(SMALL)
    key = plan_memo.plan_key(full)
    assert plan_memo.plan_key(sweep_overrides([*SMALL, "seed=5"])) != key
    conf = tmp_path / "conf"
    shutil.copytree(CONF_DIR, conf)
    from mapush import config

    monkeypatch.setattr(config, "CONF_DIR", conf)
    assert plan_memo.plan_key(full) == key  # the same files elsewhere
    task = conf / "task" / "cuboid.yaml"
    task.write_text(task.read_text() + "\n# edited\n")
    assert plan_memo.plan_key(full) != key


def test_a_damaged_memo_is_composed_again(cache, monkeypatch):
    full = sweep_overrides(SMALL)
    composed = planned_jobs(full)
    (memo,) = cache.glob("*.json")
    whole = json.loads(memo.read_text())
    memo.write_text(memo.read_text()[:100])  # cut
    monkeypatch.setattr(plan_memo, "_READ", {})
    assert plan_memo.recall(full) is None
    for altered in ({**whole, "jobs": 5}, {"jobs": [{**whole["jobs"][0], "cfg": "${oops"}]}):
        memo.write_text(json.dumps(altered))
        monkeypatch.setattr(plan_memo, "_READ", {})
        assert plan_memo.recall(full) is None
    assert _as_data(planned_jobs(full)) == _as_data(composed)


def test_the_environment_a_config_reads_is_in_the_key_and_files_beside_the_groups_are_not(cache, tmp_path, monkeypatch):
    mine = tmp_path / "mine"
    (mine / "task").mkdir(parents=True)
    task = (CONF_DIR / "task" / "cuboid.yaml").read_text().replace("name: cuboid", "name: envcube")
    (mine / "task" / "envcube.yaml").write_text(task + "\nspawn_note: ${oc.env:PUSH_TEST_MU,0.4}\n")
    full = [*SMALL, f"hydra.searchpath=[file://{mine}]"]
    monkeypatch.delenv("PUSH_TEST_MU", raising=False)
    monkeypatch.delenv("PLAN_MEMO_TEST_ONLY", raising=False)
    key = plan_memo.plan_key(full)
    monkeypatch.setenv("PLAN_MEMO_TEST_ONLY", "1")  # read by no config: the same plan
    assert plan_memo.plan_key(full) == key
    monkeypatch.setenv("PUSH_TEST_MU", "0.45")  # read by the task: another plan
    assert plan_memo.plan_key(full) != key
    monkeypatch.delenv("PUSH_TEST_MU")
    (mine / "runs" / "a").mkdir(parents=True)
    (mine / "runs" / "a" / "config.yaml").write_text("seed: 1\n")  # a run dir under the search path: no config
    assert plan_memo.plan_key(full) == key
    (mine / "task" / "envcube.yaml").write_text(task)
    assert plan_memo.plan_key(full) != key


def test_a_curve_or_budget_rule_with_keys_a_result_cannot_hold_is_refused_before_launch(cache):
    with pytest.raises(BadInput, match=r"budget smoke's curve has unknown keys \['note'\]; valid: eval, "):
        sweep_overrides([*SMALL, "+experiment.budgets.smoke.curve.note=x"])
    with pytest.raises(BadInput, match=r"budget_rule has \['max_gain', 'tail', 'tial'\]; valid: tail, max_gain"):
        sweep_overrides([*SMALL, "+experiment.budget_rule.tial=0.2"])
