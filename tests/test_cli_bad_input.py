"""User mistakes through the real CLI: one line on stderr naming the bad value and the valid choices, exit code 2,
no traceback, and nothing written or overwritten."""

from __future__ import annotations

import pytest


def assert_bad_input(proc, *fragments: str) -> str:
    """Exit 2 with exactly one `mapush: error:` line on stderr that contains every fragment; returns the line."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("mapush: error: ")
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


@pytest.fixture
def train_bad(cli, tmp_path):
    """`train_bad(override)`: a smoke training with one bad override; asserts no run dir was made."""

    def run(*overrides: str):
        runs = tmp_path / "runs"
        proc = cli("train", "debug=smoke", f"train.run_root={runs}", *overrides)
        assert not runs.exists() or not any(runs.rglob("*")), "a run dir was made for a bad input"
        return proc

    return run


def test_unknown_task(train_bad):
    assert_bad_input(train_bad("task=sphere"), "'sphere'", "valid: cuboid, cylinder, ocb_cuboid, tblock")


def test_unknown_level(train_bad):
    assert_bad_input(train_bad("level=flying"), "'flying'", "high", "low", "mid")


def test_unknown_reward_term(train_bad):
    assert_bad_input(train_bad("reward.terms.foo.weight=1"), "foo", "subgoal_reached", "ocb")


def test_unknown_config_key(train_bad):
    assert_bad_input(train_bad("train.iterationz=3"), "iterationz", "iterations", "run_root")


@pytest.mark.parametrize(
    ("override", "unknown"),
    [("reward.terms.foo.weight=1", "reward.terms.foo"), ("train.iterationz=3", "train.iterationz")],
)
def test_unknown_key_exits_2_with_one_line_naming_it(train_bad, override, unknown):
    assert_bad_input(train_bad(override), f"'{unknown}'")


def test_a_randomized_range_that_is_not_one(train_bad):
    assert_bad_input(
        train_bad("lowlevel.randomize={lag:[0.3,0.1]}"), "lowlevel.randomize.lag=[0.3, 0.1]", "0 < low <= high"
    )


@pytest.mark.parametrize("num_agents", [40, 0])
def test_agent_count_that_does_not_fit_the_spawn_ring(train_bad, num_agents):
    # cuboid ring r = 1.2 m, robots >= 0.75 m apart: at most 9
    assert_bad_input(train_bad(f"task.num_agents={num_agents}"), f"task.num_agents={num_agents}", "valid: 1 to 9")


@pytest.mark.parametrize("override", ["seed=abc", "num_envs=0"])
def test_ill_typed_value(train_bad, override):
    assert_bad_input(train_bad(override), override.partition("=")[2])


def test_eval_of_a_missing_checkpoint(cli, run_copy, snapshot):
    before = snapshot(run_copy)
    missing = run_copy / "model_99.pt"
    assert_bad_input(cli("eval", missing), str(missing), "valid: a run dir or a model_<iteration>.pt")
    assert snapshot(run_copy) == before


def test_eval_of_a_missing_run_dir(cli, tmp_path):
    assert_bad_input(cli("eval", tmp_path / "nowhere"), "nowhere", "valid: a run dir")


def test_eval_with_another_agent_count_than_the_checkpoint(cli, run_copy, snapshot):
    # trained with 2 agents: a 10-d local observation; 3 agents give 6 + 4 * 2 = 14-d
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "task.num_agents=3"), "3 agents", "14-d", "10-d", "valid:")
    assert snapshot(run_copy) == before


def test_eval_with_another_agent_count_names_the_trained_count(cli, run_copy):
    assert_bad_input(cli("eval", run_copy, "task.num_agents=3"), "task.num_agents=2")


def test_eval_refuses_a_checkpoint_holding_more_than_weights(cli, run_copy, snapshot):
    import argparse

    import torch

    last = sorted(run_copy.glob("model_*.pt"))[-1]
    data = torch.load(last, weights_only=True)
    data["infos"] = argparse.Namespace(note="any pickled object could run code when loaded")
    torch.save(data, last)
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", last), str(last), "other than weights", "valid:")
    assert snapshot(run_copy) == before


def test_eval_with_zero_episodes(cli, run_copy, snapshot):
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "--episodes", "0"), "--episodes 0", "valid: 1 or more")
    assert snapshot(run_copy) == before


def test_resume_of_a_dir_that_is_not_a_run(cli, tmp_path, snapshot):
    not_a_run = tmp_path / "notes"
    not_a_run.mkdir()
    (not_a_run / "readme.txt").write_text("not a run\n")
    before = snapshot(not_a_run)
    assert_bad_input(cli("train", "--resume", not_a_run), str(not_a_run), "is not a run dir", "valid:")
    assert snapshot(not_a_run) == before


def test_resume_with_another_override_than_the_iteration_count(cli, run_copy, snapshot):
    before = snapshot(run_copy)
    assert_bad_input(cli("train", "--resume", run_copy, "seed=1"), "'seed=1'", "train.iterations=N")
    assert snapshot(run_copy) == before


@pytest.mark.parametrize(
    ("override", "valid"),
    [
        ("sim.timestep=0", "a positive time step"),
        ("sim.decimation=-1", "an integer >= 1"),
        ("algo.algorithm.learning_rate=-1e-3", "a positive learning rate"),
        ("algo.algorithm.gamma=1.5", "(0, 1]"),
        ("task.object.parts.0.mass=0", "a positive mass"),
        ("task.object.parts.0.size=[1.2,0,0.5]", "3 positive numbers"),
        ("task.object.hull=[[0,0],[1,0],[2,0]]", "encloses no area"),
    ],
)
def test_physically_meaningless_number(train_bad, override, valid):
    key = override.partition("=")[0].replace(".0.", "[0].") if ".parts." in override else override.partition("=")[0]
    assert_bad_input(train_bad(override), key, valid)


@pytest.mark.slow
def test_eval_parses_values_as_train_does(cli, run_copy, snapshot):
    """`5e-3` is a float to Hydra (train) and was a string to YAML 1.1 (eval's old parser): now both check it."""
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "sim.timestep=-5e-3"), "sim.timestep=-0.005", "a positive time step")
    assert_bad_input(cli("eval", run_copy, "+sim.timestep=1e-3"), "'sim.timestep' already exists")
    assert_bad_input(cli("eval", run_copy, "seed=0,1"), "is a sweep")
    assert snapshot(run_copy) == before
