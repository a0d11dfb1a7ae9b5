"""`mapush train debug=smoke` and `mapush eval` through the installed command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
import yaml
from mcap.reader import make_reader


def topics_and_iterations(path) -> dict[str, list[int]]:
    """Every topic of a metrics MCAP file with the iterations of its messages."""
    found: dict[str, list[int]] = {}
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            found.setdefault(channel.topic, []).append(json.loads(message.data)["iteration"])
    return found


def test_train_prints_the_run_dir_under_the_run_root(smoke_run):
    # <run_root>/<level>/<task>/<time>__seed<seed>
    assert smoke_run.parent.name == "cuboid"
    assert smoke_run.parent.parent.name == "mid"
    assert smoke_run.name.endswith("__seed0")


def test_train_leaves_config_checkpoints_metrics_and_policy(smoke_run):
    names = {p.name for p in smoke_run.iterdir()}
    assert {"config.yaml", "model_0.pt", "model_1.pt", "metrics.mcap", "policy.pt", "train.log"} <= names


def test_saved_config_is_the_composed_smoke_config(smoke_run, smoke_cfg):
    saved = yaml.safe_load((smoke_run / "config.yaml").read_text())
    assert saved["train"]["iterations"] == 2
    assert saved["task"] == smoke_cfg["task"]
    assert saved["reward"] == smoke_cfg["reward"]


def test_last_checkpoint_is_the_last_iteration(smoke_run):
    # 2 iterations are numbered 0 and 1
    data = torch.load(smoke_run / "model_1.pt", weights_only=False, map_location="cpu")
    assert data["iter"] == 1


def test_metrics_record_each_iteration(smoke_run):
    topics = topics_and_iterations(smoke_run / "metrics.mcap")
    assert topics["/metrics/Loss/learning_rate"] == [0, 1]
    assert topics["/metrics/Train/mean_reward"] == [0, 1]
    assert "/metrics/Reward/ocb" in topics


def test_metrics_file_carries_the_config(smoke_run):
    with open(smoke_run / "metrics.mcap", "rb") as f:
        names = {a.name for a in make_reader(f).iter_attachments()}
    assert {"config.json", "train_cfg.json"} <= names


@pytest.mark.filterwarnings("ignore:`torch.jit.load` is deprecated:DeprecationWarning")
def test_exported_policy_maps_a_local_observation_to_an_action(smoke_run):
    # cuboid, 2 agents: 10-d local observation -> (vx, vy, yaw rate)
    policy = torch.jit.load(str(smoke_run / "policy.pt"))
    assert policy(torch.zeros(5, 10)).shape == (5, 3)


@pytest.mark.slow  # over 8 s on the idle 2-core machine (10-11 s, 2026-12-07)
def test_eval_writes_success_rate_and_completion_time(cli, run_copy):
    proc = cli("eval", run_copy)
    assert proc.returncode == 0, proc.stderr
    result = json.loads((run_copy / "eval.json").read_text())
    assert {"success_rate", "success_rate_std", "completion_time", "completion_time_s", "episodes", "seeds"} <= set(
        result
    )
    # smoke: 2 episodes x seed 0, 1 s timeout
    assert (result["episodes"], result["seeds"]) == (2, [0])
    assert 0.0 <= result["success_rate"] <= 1.0
    assert 0.0 <= result["completion_time"] <= 1.0
    assert result["completion_time_s"] == result["completion_time"] * result["timeout_s"]
    assert result["timeout_s"] == 1.0
    assert result["checkpoint"].endswith("model_1.pt")
    assert str(run_copy / "eval.json") in proc.stdout


@pytest.mark.slow
def test_eval_takes_episodes_seeds_and_a_name(cli, run_copy):
    before = sorted(p.name for p in run_copy.iterdir())
    proc = cli("eval", run_copy / "model_0.pt", "--episodes", "3", "--seeds", "4,5", "--name", "other_seeds")
    assert proc.returncode == 0, proc.stderr
    added = sorted(set(p.name for p in run_copy.iterdir()) - set(before))
    assert added == ["episodes_other_seeds.mcap", "eval_other_seeds.json"]  # the run's own eval.json is left alone
    result = json.loads((run_copy / "eval_other_seeds.json").read_text())
    assert (result["episodes"], result["seeds"], len(result["per_seed"])) == (3, [4, 5], 2)
    assert result["checkpoint"].endswith("model_0.pt")


@pytest.mark.slow
def test_the_same_seed_gives_the_same_trained_weights(cli, tmp_path, smoke_run):
    """Two smoke trainings with seed 0 end with identical actor weights; seed 1 ends elsewhere."""

    def final_actor(seed: int, root: Path) -> dict:
        proc = cli("train", "debug=smoke", f"seed={seed}", f"train.run_root={root}")
        assert proc.returncode == 0, proc.stderr
        run_dir = Path(proc.stdout.strip().splitlines()[-1])
        return torch.load(run_dir / "model_1.pt", weights_only=False)["actor_state_dict"]

    reference = torch.load(smoke_run / "model_1.pt", weights_only=False)["actor_state_dict"]
    again, other = final_actor(0, tmp_path / "a"), final_actor(1, tmp_path / "b")
    assert all(torch.equal(reference[k], again[k]) for k in reference)
    assert any(not torch.equal(reference[k], other[k]) for k in reference)
