"""User mistakes through the real CLI: one line on stderr naming the bad value and the valid choices, exit code 2,
no traceback, and nothing written or overwritten."""

from __future__ import annotations

import pytest
from stand_ins import assert_bad_input

from mapush.errors import BadInput


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
    assert_bad_input(train_bad("level=flying"), "'flying'", "high", "locomotion", "mid")


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


@pytest.mark.slow
def test_a_randomized_range_that_is_not_one(train_bad):
    assert_bad_input(
        train_bad("lowlevel.randomize={lag:[0.3,0.1]}"), "lowlevel.randomize.lag=[0.3, 0.1]", "0 < low <= high"
    )


@pytest.mark.parametrize("num_agents", [40, 0])
@pytest.mark.slow
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


@pytest.mark.slow
def test_eval_with_another_agent_count_than_the_checkpoint(cli, run_copy, snapshot):
    # trained with 2 agents: a 10-d local observation; 3 agents give 6 + 4 * 2 = 14-d
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "task.num_agents=3"), "3 agents", "14-d", "10-d", "valid:")
    assert snapshot(run_copy) == before


@pytest.mark.slow
def test_eval_with_another_agent_count_names_the_trained_count(cli, run_copy):
    assert_bad_input(cli("eval", run_copy, "task.num_agents=3"), "task.num_agents=2")


@pytest.mark.slow  # over 8 s on the idle 2-core machine (10-11 s, 2026-12-07)
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
@pytest.mark.slow
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


@pytest.mark.parametrize(
    ("node", "entry"),
    [
        ("reward.terms.*", {"func": "pydoc:pipepager", "params": {"text": "x", "cmd": "touch {mark}"}}),
        ("algo.algorithm", {"class_name": "pydoc:pipepager", "text": "x", "cmd": "touch {mark}"}),
        ("algo.actor", {"class_name": "pydoc.pipepager", "text": "x", "cmd": "touch {mark}"}),
    ],
)
@pytest.mark.parametrize("command", ["eval", "resume"])
@pytest.mark.slow
def test_a_run_dir_whose_config_names_foreign_code_is_refused_and_runs_nothing(
    cli, run_copy, snapshot, tmp_path, node, entry, command
):
    """A shared run dir is data: its config.yaml cannot make `mapush eval` or `--resume` run a shell command."""
    from omegaconf import OmegaConf

    mark = tmp_path / "pwned"
    cfg = OmegaConf.load(run_copy / "config.yaml")
    if node.endswith("*"):  # the run's first reward term
        node = f"reward.terms.{next(iter(cfg.reward.terms))}"
    attack = {k: (v.format(mark=mark) if k == "cmd" else v) for k, v in entry.items()}
    attack["params"] = {k: (v.format(mark=mark) if k == "cmd" else v) for k, v in attack.get("params", {}).items()}
    if not attack["params"]:
        attack.pop("params")
    OmegaConf.update(cfg, node, {**OmegaConf.to_container(OmegaConf.select(cfg, node)), **attack}, merge=False)
    OmegaConf.save(cfg, run_copy / "config.yaml")
    before = snapshot(run_copy)
    args = (
        ("eval", run_copy, "--episodes", "1")
        if command == "eval"
        else ("train", "--resume", run_copy, "train.iterations=4")
    )
    assert_bad_input(cli(*args), "pipepager", "refused", "mapush --trust pydoc")
    assert not mark.exists()
    assert snapshot(run_copy) == before


@pytest.mark.slow
def test_a_module_the_user_trusts_on_the_command_line_may_be_named(cli, tmp_path, monkeypatch):
    """`mapush --trust MODULE` lets a config name that module's terms (here a reward term of the user's own)."""
    (tmp_path / "my_terms.py").write_text("def still(env):\n    return env.state.robot_xy[..., 0] * 0\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    term = "+reward.terms.still={func:my_terms:still,weight:1.0}"
    runs = tmp_path / "runs"
    refused = cli("train", "debug=smoke", f"train.run_root={runs}", term)
    assert_bad_input(refused, "my_terms:still", "mapush --trust my_terms")
    trusted = cli("--trust", "my_terms", "train", "debug=smoke", f"train.run_root={runs}", term)
    assert trusted.returncode == 0, trusted.stderr


@pytest.mark.parametrize(
    ("override", "valid"),
    [
        ("reward.terms.subgoal_reached.weight=nan", "a finite number"),
        ("reward.terms.subgoal_reached.weight=inf", "a finite number"),
        ("task.name={a:1}", "a name of letters"),
        ("task.name=../../x", "a name of letters"),
    ],
)
def test_a_number_or_name_that_cannot_be_is_refused(override, valid):
    from mapush.config import compose_config  # what `mapush train` composes first; the CLI's line: the test below

    with pytest.raises(BadInput) as refused:
        compose_config(["debug=smoke", override])
    assert override.partition("=")[0] in str(refused.value) and valid in str(refused.value)


def test_a_number_that_cannot_be_is_one_line_and_makes_no_run_dir(train_bad):
    override = "reward.terms.subgoal_reached.weight=nan"
    assert_bad_input(train_bad(override), override.partition("=")[0], "a finite number")


@pytest.mark.parametrize("args", [("-m", "seed=0,1"), ("seed=0,1",), ("--multirun", "task=cuboid"), ("seed=range(2)",)])
def test_hydra_multirun_habits_point_to_mapush_sweep(args):
    from mapush.commands.run_commands import train  # refused before it composes; the CLI's line: the test below

    with pytest.raises(BadInput) as refused:
        train(list(args), resume=None, show=None)
    line = str(refused.value)
    assert "\n" not in line and all(part in line for part in ("not a sweep", "valid:", "`mapush sweep"))
    assert "-m" not in line.partition("`mapush sweep")[2] and "--multirun" not in line.partition("`mapush sweep")[2]


def test_a_multirun_habit_on_the_command_line_is_one_line_and_makes_no_run_dir(train_bad):
    assert_bad_input(train_bad("-m", "seed=0,1"), "not a sweep", "valid:", "`mapush sweep")


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_a_smoke_multirun_points_to_a_small_sweep_that_plans_only_that(train_bad, cli):
    line = assert_bad_input(train_bad("seed=0,1"), "not a sweep", "valid:", "`mapush sweep")
    hint = line.partition("`mapush sweep ")[2].partition("`")[0].split()
    assert {"method=ours", "task=cuboid", "budget=smoke", "seed=0,1"} <= set(hint), line
    planned = cli("sweep", *hint, "--dry-run")  # its root is the refused run's (`train.run_root`): fresh
    assert planned.returncode == 0, planned.stderr
    assert "2 jobs" in planned.stdout and "smoke" in planned.stdout, planned.stdout


@pytest.mark.parametrize("text", ["", "{", "- a list\n", "level: {name: mid}\n"])
def test_a_run_whose_config_yaml_is_torn_or_empty_is_refused_naming_it(tmp_path, text):
    from mapush.config import load_run_config  # what eval and resume read first; the CLI's line: the test below

    (tmp_path / "config.yaml").write_text(text)
    with pytest.raises(BadInput) as refused:
        load_run_config(tmp_path)
    line = str(refused.value)
    assert "\n" not in line and "config.yaml" in line and "valid: the config.yaml a run was made" in line


def test_a_run_whose_config_yaml_is_torn_is_one_line_to_eval_and_resume(cli, run_copy, snapshot):
    (run_copy / "config.yaml").write_text("{")
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "--episodes", "1"), "config.yaml", "valid: the config.yaml a run was made")
    assert_bad_input(cli("train", "--resume", run_copy, "train.iterations=4"), "config.yaml")
    assert snapshot(run_copy) == before


@pytest.mark.slow
def test_a_locomotion_policy_that_is_not_torchscript_is_one_line(train_bad, tmp_path):
    fake = tmp_path / "policy.pt"
    fake.write_bytes(b"not a zip archive")
    assert_bad_input(train_bad("lowlevel=go1", f"lowlevel.policy={fake}"), "is not a TorchScript policy", "valid:")


@pytest.mark.slow
def test_more_envs_than_memory_holds_is_one_line_naming_the_most(train_bad):
    line = assert_bad_input(train_bad("num_envs=100000000"), "num_envs=100000000", "GiB", "valid: num_envs <=")
    most = int(line.rpartition("<= ")[2])
    assert 1000 < most < 100000000


def test_adopting_a_dir_that_is_no_run_is_one_line_and_adopts_nothing(cli, tmp_path):
    (tmp_path / "notarun").mkdir()
    proc = cli("stages", "adopt", "--run", tmp_path / "notarun", "experiment=main", f"sweep_root={tmp_path / 's'}")
    assert_bad_input(proc, "--run", "notarun", "not a run dir", "valid:")
    assert not (tmp_path / "s").exists()
