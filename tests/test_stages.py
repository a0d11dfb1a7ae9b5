"""Stages trained once: identity from the composed config, reuse across jobs and experiments, the dry run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mapush.config import compose_config
from mapush.experiments.pipeline import RESULT, planned_stages
from mapush.rundir import find_runs

SMOKE = ["budget=smoke", "debug=smoke"]


def _identities(*overrides: str) -> dict[str, str]:
    cfg = compose_config(["experiment=main", "method=ours", "task=cuboid", *overrides], config_name="sweep")
    return {stage.name: stage.identity for stage in planned_stages(cfg)}


def test_equal_stage_configs_have_one_identity_whatever_the_job_that_composes_them():
    # SA's mid level of the cylinder is the scalability study's 1-robot mid level, composed from other overrides
    sa = compose_config(["experiment=main", "method=sa", "task=cylinder"], config_name="sweep")
    scale = compose_config(["experiment=scale", "method=ours", "task=cylinder", "agents=1"], config_name="sweep")
    assert [s.identity for s in planned_stages(sa)] == [s.identity for s in planned_stages(scale)]
    # where a stage is written, with how many threads, how it is logged and how many checkpoints it keeps do not
    # make another stage
    assert _identities() == _identities(
        "overrides=['sim.nthread=1','log.episode_interval=0','train.progress=false','algo.keep_checkpoints=0',"
        "'algo.save_interval=7']"
    )


def test_a_changed_reward_weight_tracker_value_or_budget_is_another_stage():
    base = _identities()
    for changed in (
        "method.stages.mid=['level=mid','reward.terms.ocb.weight=0.01']",
        "overrides=['lowlevel.max_force=40.0']",
        "experiment.budgets.quick.stages.mid.env_steps=5.0e6",
        "seed=1",
    ):
        other = _identities(changed)
        assert other["mid"] != base["mid"], changed
        assert other["high"] != base["high"], changed  # the high level sits on another mid level
    # a high-level change leaves the mid level shared
    high_only = _identities("experiment.budgets.quick.stages.high.env_steps=3.0e6")
    assert high_only["mid"] == base["mid"] and high_only["high"] != base["high"]


def test_a_sweep_stage_writes_a_checkpoint_by_every_mark_of_its_learning_curve():
    cfg = compose_config(["experiment=main", "method=ours", "task=cuboid"], config_name="sweep")
    mid, high = planned_stages(cfg)
    # quick budget, curve marks every 2.5M env-steps. mid: 500 envs x 24 steps = 12,000 env-steps per iteration,
    # 208 iterations between marks, so algo/mappo.yaml's 50 stands. high: 128 envs x 32 decisions x 25 control
    # steps = 102,400 env-steps per iteration, 24 between marks: every 23 iterations instead of ppo_high.yaml's 50,
    # so model_46.pt (47 iterations, 4.81M env-steps) comes before the 5M mark, where model_48.pt (5.02M) would not
    assert (mid.save_interval, high.save_interval) == (50, 23)


def _sweep(cli, root, *args):
    return cli(*args, *SMOKE, f"sweep_root={root}")


@pytest.mark.slow
def test_a_stage_trained_by_one_experiment_is_reused_by_another_and_the_dry_run_says_so(cli, tmp_path, snapshot):
    root = tmp_path / "sweeps"
    plan = _sweep(cli, root, "sweep", "--dry-run", "experiment=main", "method=sa", "task=cylinder")
    assert plan.returncode == 0, plan.stderr
    assert "2 to train" in plan.stdout and plan.stdout.count("  train  ") == 2
    assert not root.exists()  # the dry run trains and writes nothing

    first = _sweep(cli, root, "sweep", "experiment=main", "method=sa", "task=cylinder")
    assert first.returncode == 0, first.stdout + first.stderr
    before = snapshot(root)
    plan = _sweep(cli, root, "scale", "--agents", "1", "--dry-run")
    assert plan.returncode == 0, plan.stderr
    assert "0 to train" in plan.stdout and plan.stdout.count("  reuse  ") == 2
    assert snapshot(root) == before

    second = _sweep(cli, root, "scale", "--agents", "1")
    assert second.returncode == 0, second.stdout + second.stderr
    results = [json.loads(p.read_text()) for p in sorted(root.glob(f"*/*/{RESULT}"))]
    assert sorted(r["experiment"] for r in results) == ["main", "scale"]
    assert results[0]["stages"] == results[1]["stages"]  # both cells name the same run dirs
    mid_eval = Path(results[1]["evals"]["mid"]["file"])  # the study also evaluates the mid level alone
    assert mid_eval.parent == Path(results[1]["stages"]["mid"]) and mid_eval.name == "eval_mid.json"
    assert len(find_runs(root / "stages")) == 2  # one mid and one high run in all
    for run in map(Path, results[0]["stages"].values()):
        assert sorted(p.name for p in run.glob("model_*.pt")) == ["model_0.pt"]  # trained once, not resumed
