"""Configs of your own, outside the package: a task file found through `hydra.searchpath`, trained and swept."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from omegaconf import OmegaConf
from stand_ins import assert_bad_input

from mapush.config import CONF_DIR


def _my_task(root: Path) -> Path:
    """`<root>/task/long_box.yaml`: the cuboid, 2 m long, named long_box, its robots' ring widened to clear it."""
    task = OmegaConf.load(CONF_DIR / "task" / "cuboid.yaml")
    task.name = "long_box"
    task.object.parts[0].size[0] = 2.0
    task.spawn.agent_radius = [1.6, 1.7]
    (root / "task").mkdir(parents=True)
    OmegaConf.save(task, root / "task" / "long_box.yaml")
    return root


@pytest.mark.slow
def test_a_task_from_a_directory_of_yours_trains_and_evaluates(cli, tmp_path):
    mine = _my_task(tmp_path / "my_configs")
    runs = tmp_path / "runs"
    proc = cli("train", f"hydra.searchpath=[file://{mine}]", "task=long_box", "debug=smoke", f"train.run_root={runs}")
    assert proc.returncode == 0, proc.stderr
    run_dir = Path(proc.stdout.strip().splitlines()[-1])
    assert run_dir.parent == runs / "mid" / "long_box"
    assert OmegaConf.load(run_dir / "config.yaml").task.object.parts[0].size[0] == 2.0
    evaluated = cli("eval", run_dir, "--episodes", "1", "--seeds", "0")  # the run dir holds the task: no searchpath
    assert evaluated.returncode == 0, evaluated.stderr
    assert json.loads((run_dir / "eval.json").read_text())["task"] == "long_box"


@pytest.mark.slow
def test_a_task_from_a_directory_of_yours_is_swept_and_its_dry_run_names_it(cli, tmp_path):
    mine = _my_task(tmp_path / "my_configs")
    sweep = ["sweep", "experiment=main", "method=ours,sa", "task=long_box", f"hydra.searchpath=[file://{mine}]"]
    sweep += ["budget=smoke", "debug=smoke", f"sweep_root={tmp_path / 'sweeps'}"]
    planned = cli(*sweep, "--dry-run")
    assert planned.returncode == 0, planned.stderr
    assert "2 jobs, 0 finished" in planned.stdout and "method=ours,seed=0,task=long_box  mid" in planned.stdout
    proc = cli(*sweep)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    results = sorted((tmp_path / "sweeps").glob("main_smoke_debug-smoke/*/result.json"))
    # named as any job, the searchpath left out
    assert [r.parent.name for r in results] == [f"method={m},seed=0,task=long_box" for m in ("ours", "sa")]
    for run_dir in json.loads(results[0].read_text())["stages"].values():
        assert OmegaConf.load(Path(run_dir) / "config.yaml").task.object.parts[0].size[0] == 2.0
    tables = cli("tables", "--runs", tmp_path / "sweeps", "--table", "main", "--out", tmp_path / "tables")
    assert tables.returncode == 0, tables.stderr  # the SA finding composes the task: its jobs say where it is
    assert "long_box: SA" in (tmp_path / "tables" / "main_smoke_debug-smoke").with_suffix(".md").read_text()
    unknown = cli("sweep", "experiment=main", "task=long_box", "budget=smoke", f"sweep_root={tmp_path / 's2'}")
    assert_bad_input(unknown, "unknown task 'long_box'", "valid: cuboid")


def test_a_searchpath_hydra_does_not_read_is_refused(cli, tmp_path):
    mine = _my_task(tmp_path / "my_configs")
    for command in ("train", "sweep"):
        proc = cli(command, f"+hydra.searchpath=[file://{mine}]", "task=long_box", f"train.run_root={tmp_path / 'r'}")
        assert_bad_input(proc, "+hydra.searchpath", "valid: hydra.searchpath=[file:///DIR]")
    assert not (tmp_path / "r").exists()


def test_without_the_searchpath_the_task_is_unknown_and_the_message_says_how(cli, tmp_path):
    _my_task(tmp_path / "my_configs")
    proc = cli("train", "task=long_box", "debug=smoke", f"train.run_root={tmp_path / 'runs'}")
    assert_bad_input(proc, "unknown task 'long_box'", "hydra.searchpath", "cuboid")


def test_a_task_file_that_kept_another_task_s_name_is_refused_before_anything_is_written(cli, tmp_path):
    mine = tmp_path / "my_configs"
    (mine / "task").mkdir(parents=True)
    (mine / "task" / "wide_box.yaml").write_text((CONF_DIR / "task" / "cuboid.yaml").read_text())  # name: cuboid
    runs = tmp_path / "runs"
    proc = cli("train", f"hydra.searchpath=[file://{mine}]", "task=wide_box", "debug=smoke", f"train.run_root={runs}")
    assert_bad_input(proc, "task=wide_box", "name: cuboid", "valid: name: wide_box")
    assert not runs.exists()


def test_a_task_weight_no_reward_term_reads_is_refused(tmp_path):
    from mapush.config import compose_config
    from mapush.errors import BadInput

    mine = _my_task(tmp_path / "my_configs")
    task = OmegaConf.load(mine / "task" / "long_box.yaml")
    task.reward_weights = {"robot_jam": 0.0, "ocb_weight": 1.0}  # a typo of `ocb`
    OmegaConf.save(task, mine / "task" / "long_box.yaml")
    for level in ("mid", "high"):  # whichever level, a task's weight that no reward file reads is a typo
        with pytest.raises(BadInput, match=r"reward_weights.ocb_weight is read by no reward term; valid: .*ocb, "):
            compose_config([f"hydra.searchpath=[file://{mine}]", "task=long_box", f"level={level}"])
    task.reward_weights = {"robot_jam": 0.0, "ocb": 1.0}
    OmegaConf.save(task, mine / "task" / "long_box.yaml")
    weights = compose_config([f"hydra.searchpath=[file://{mine}]", "task=long_box", "~reward.terms.ocb"]).task
    assert weights.reward_weights.ocb == 1.0  # a term the command line drops leaves its task weight valid


def test_a_spawn_ring_that_starts_robots_inside_the_object_is_refused(cli, tmp_path):
    mine = _my_task(tmp_path / "my_configs")
    task = OmegaConf.load(mine / "task" / "long_box.yaml")
    task.spawn.agent_radius = [1.2, 1.3]  # the cuboid's ring; the 2 m box reaches 1.17 m from its centre
    OmegaConf.save(task, mine / "task" / "long_box.yaml")
    runs = tmp_path / "runs"
    proc = cli("train", f"hydra.searchpath=[file://{mine}]", "task=long_box", "debug=smoke", f"train.run_root={runs}")
    assert_bad_input(proc, "task.spawn.agent_radius=[1.2, 1.3]", "long_box", "valid: an inner radius above 1.491 m")
    assert not runs.exists()


def test_a_config_composed_again_is_a_copy_and_follows_its_file_when_it_changes(tmp_path):
    from mapush.config import compose_config

    mine = _my_task(tmp_path / "my_configs")
    overrides = [f"hydra.searchpath=[file://{mine}]", "task=long_box"]
    first = compose_config(overrides)
    first.task.object.parts[0].size[0] = 9.0  # a caller's edit stays in its own copy
    assert compose_config(overrides).task.object.parts[0].size[0] == 2.0
    task = OmegaConf.load(mine / "task" / "long_box.yaml")
    task.object.parts[0].size[0] = 3.25
    OmegaConf.save(task, mine / "task" / "long_box.yaml")
    assert compose_config(overrides).task.object.parts[0].size[0] == 3.25
