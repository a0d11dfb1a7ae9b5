"""Shipping a hierarchy (`mapush ship`) and the policies shipped in the package (`shipped:NAME`)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
import torch
from conftest import _run_cli
from omegaconf import OmegaConf

from mapush.commands.ship import without_machine_paths
from mapush.eval.numerics import computes_alike
from mapush.rl.policy import load_policy
from mapush.rundir import PACKAGE, SHIPPED_LOWLEVEL, shipped_names, shipped_run

HIERARCHIES = [n for n in shipped_names() if not (SHIPPED_LOWLEVEL / n).is_dir() and not n.endswith("/mid")]
"""The shipped pushing hierarchies by their high level (not the locomotion policies, not the mid levels)."""


@pytest.fixture(scope="module")
def high_run(smoke_run, tmp_path_factory) -> Path:
    """A 1-iteration high level over the smoke mid level, made once through the CLI. Read-only."""
    root = tmp_path_factory.mktemp("high_runs")
    proc = _run_cli(["train", "level=high", f"mid={smoke_run}", "debug=smoke", f"train.run_root={root}"], cwd=root)
    assert proc.returncode == 0, proc.stderr
    return Path(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_high_level_ships_with_its_mid_level_and_evaluates_from_anywhere(cli, high_run, smoke_run, tmp_path):
    out = tmp_path / "package" / "cuboid"
    proc = cli("ship", high_run, out, "--episodes", "2", "--seeds", "0")
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["high", "mid"]
    assert OmegaConf.load(out / "high" / "config.yaml").mid == "../mid"  # relative: the package can move
    result = json.loads((out / "high" / "eval.json").read_text())
    assert result["episodes"] == 2 and 0.0 <= result["success_rate"] <= 1.0
    moved = tmp_path / "elsewhere"
    (out).rename(moved)
    for level, source in (("mid", smoke_run), ("high", high_run)):
        shipped, trained = load_policy(moved / level), load_policy(source)
        obs = torch.randn(8, shipped.obs_dim)
        assert torch.equal(shipped.actor(obs), trained.actor(obs))
    again = cli("eval", moved / "high", "--episodes", "1", "--seeds", "0")
    assert again.returncode == 0, again.stderr


@pytest.mark.slow
def test_shipping_an_unfinished_run_is_refused_and_writes_nothing(cli, run_copy, tmp_path):
    (run_copy / "policy.pt").unlink()
    out = tmp_path / "out"
    proc = cli("ship", run_copy, out)
    assert proc.returncode == 2 and "is not finished" in proc.stderr and not out.exists()


def test_an_unknown_shipped_name_lists_the_shipped_ones(cli):
    proc = cli("eval", "shipped:sphere")
    assert proc.returncode == 2
    assert "'sphere'" in proc.stderr and "shipped:go1" in proc.stderr


@pytest.mark.parametrize("name", [n for n in shipped_names() if n not in HIERARCHIES])  # those: reproduced below
@pytest.mark.slow
def test_every_other_shipped_policy_loads_and_runs_one_episode_without_writing_into_the_package(cli, name, tmp_path):
    before = {p: p.stat().st_mtime_ns for p in shipped_run(name).rglob("*")}
    # one whole episode, cut to 20 s (a high level's 160 s would take 10-15 s of CPU); its eval file is named so
    proc = cli("eval", f"shipped:{name}", "--episodes", "1", "--seeds", "0", "level.episode_length_s=20")
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "runs" / "shipped" / shipped_run(name).relative_to(PACKAGE) / "eval_level.episode-length-s-20.json"
    assert json.loads(out.read_text())["episodes"] == 1
    assert {p: p.stat().st_mtime_ns for p in shipped_run(name).rglob("*")} == before


@pytest.mark.parametrize("name", HIERARCHIES)
@pytest.mark.slow
def test_a_shipped_hierarchy_with_another_agent_count_is_refused(cli, name):
    proc = cli("eval", f"shipped:{name}", "task.num_agents=5")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "agents" in proc.stderr and "valid:" in proc.stderr


def within_evaluation_noise(again: dict, recorded: dict) -> bool:
    """Whether a seed's figures differ from the recorded ones by at most 3 standard errors of the recorded
    evaluation: binomial for S.R., the episodes' spread of C.T. over sqrt(episodes) for C.T."""
    n, p = recorded["episodes"], recorded["success_rate"]
    sr_bound = 3 * max(math.sqrt(p * (1 - p) / n), 1 / n)  # at least one episode's worth when p is 0 or 1
    ct_bound = 3 * max(recorded["completion_time_episode_std"], 1 / n) / math.sqrt(n)
    return (
        abs(again["success_rate"] - p) <= sr_bound
        and abs(again["completion_time"] - recorded["completion_time"]) <= ct_bound
    )


def test_the_noise_bound_accepts_one_flipped_episode_and_refuses_a_broken_policy():
    recorded = {"episodes": 50, "success_rate": 0.92, "completion_time": 0.344, "completion_time_episode_std": 0.2}
    assert within_evaluation_noise({"success_rate": 0.94, "completion_time": 0.3367}, recorded)  # another CPU
    assert not within_evaluation_noise({"success_rate": 0.70, "completion_time": 0.344}, recorded)
    assert not within_evaluation_noise({"success_rate": 0.92, "completion_time": 0.50}, recorded)
    assert not within_evaluation_noise({"success_rate": 0.0, "completion_time": 1.0}, recorded)


@pytest.mark.slow
@pytest.mark.parametrize("name", HIERARCHIES)
def test_a_shipped_hierarchy_reproduces_its_recorded_evaluation(cli, name, tmp_path):
    """`mapush eval shipped:NAME` on seed 0 gives what `mapush ship` recorded for seed 0: bit for bit on a machine
    that computes alike (same libraries, kernels and numerics hash), within the evaluation's noise on another; and
    writes nothing into the package."""
    recorded = json.loads((shipped_run(name) / "eval.json").read_text())
    first = recorded["per_seed"][0]
    before = {p: p.stat().st_mtime_ns for p in shipped_run(name).rglob("*")}
    episodes, seed = str(recorded["episodes"]), str(first["seed"])
    # no episode file: writing one takes an eighth of the evaluation and changes none of its figures
    # 50 whole-hierarchy episodes: minutes on a 2-core machine that other tests share; the timeout guards a hang
    proc = cli("eval", f"shipped:{name}", "--episodes", episodes, "--seeds", seed, "log.eval_episodes=0", timeout=900)
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "runs" / "shipped" / shipped_run(name).relative_to(PACKAGE) / "eval.json"
    result = json.loads(out.read_text())
    again = result["per_seed"][0]
    assert "planner_wall_clock_stops" not in again  # every plan ended on work done, none on the clock
    assert {p: p.stat().st_mtime_ns for p in shipped_run(name).rglob("*")} == before  # nothing written there
    if computes_alike(result["machine"], recorded["machine"]):
        assert again["success_rate"] == first["success_rate"]
        assert again["completion_time"] == pytest.approx(first["completion_time"], abs=1e-9)
    else:
        assert within_evaluation_noise(again, first), (again, first, result["machine"], recorded["machine"])


def test_shipped_files_name_no_directory_of_the_machine_they_were_made_on():
    for meta in PACKAGE.glob("**/meta.json"):
        command = json.loads(meta.read_text()).get("command", "")
        assert not re.search(r"(^|[\s=])/[^\s]*/", command), (meta, command)


def test_machine_paths_leave_a_command_s_names_and_values():
    command = "mapush train mid=/work/main/runs/x/mid_s0 task=cuboid train.init_from=/a/b/model_299.pt seed=0"
    assert without_machine_paths(command) == (
        "mapush train mid=.../mid_s0 task=cuboid train.init_from=.../model_299.pt seed=0"
    )
