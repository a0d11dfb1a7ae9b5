"""`algo.keep_checkpoints`: a run keeps its newest N checkpoints and its best by training success, and resumes."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import torch
from mcap.reader import make_reader

from mapush.rl.retention import SCORE_KEY, SUCCESS_TAG, to_prune
from mapush.rl.runner import MapushRunner, train_cfg_for
from mapush.rl.vecenv import AgentRowsVecEnv
from mapush.rundir import ONNX_FILE, POLICY_FILE


def names(run_dir: Path) -> list[str]:
    return sorted((p.name for p in run_dir.glob("model_*.pt")), key=lambda n: int(n[6:-3]))


def test_the_newest_n_and_the_best_are_kept_and_the_newer_of_equal_scores_is_the_best():
    found = [Path(f"model_{it}.pt") for it in range(6)]
    score = dict(zip(found, [0.1, 0.5, 0.2, 0.5, 0.3, -math.inf], strict=True)).get
    # newest 2: 4, 5; best: 0.5 at 1 and 3, the newer is 3
    assert to_prune(found, 2, score) == [Path("model_0.pt"), Path("model_1.pt"), Path("model_2.pt")]
    assert to_prune(found, 0, score) == []  # 0 keeps all
    assert to_prune(found, 6, score) == []


@pytest.fixture
def runner_of(make_env, tmp_path):
    """`runner_of(keep)`: a smoke MapushRunner logging to `tmp_path`, its MCAP writer open, as `learn` opens it."""
    made = []

    def make(keep: int) -> MapushRunner:
        env = make_env("debug=smoke")
        cfg = train_cfg_for({**env.cfg, "algo": {**env.cfg["algo"], "keep_checkpoints": keep}}, env.num_agents, 10)
        runner = MapushRunner(AgentRowsVecEnv(env), cfg, log_dir=str(tmp_path))
        runner.logger.init_logging_writer()
        made.append(runner)
        return runner

    yield make
    for runner in made:
        runner.logger.stop_logging_writer()


def save_at(runner: MapushRunner, iteration: int, success: float) -> None:
    """Save `model_<iteration>.pt` as `learn` does after an iteration that logged `success`."""
    runner.logger.writer.add_scalar(SUCCESS_TAG, success, iteration)
    runner.current_learning_iteration = iteration
    runner.save(str(Path(runner.logger.log_dir) / f"model_{iteration}.pt"))


def test_saving_with_keep_2_prunes_to_the_newest_2_and_the_best_across_a_resume(runner_of, tmp_path):
    runner = runner_of(keep=2)
    kept = []
    for it, success in enumerate([0.1, 0.5, 0.2, 0.5, 0.3, 0.4]):
        save_at(runner, it, success)
        kept.append(names(tmp_path))
    assert kept == [
        ["model_0.pt"],
        ["model_0.pt", "model_1.pt"],
        ["model_1.pt", "model_2.pt"],  # 1 (0.5) is the best
        ["model_2.pt", "model_3.pt"],  # 3 equals 1's 0.5 and is newer: the best, and among the newest
        ["model_3.pt", "model_4.pt"],
        ["model_3.pt", "model_4.pt", "model_5.pt"],  # 3 stays as the best
    ]
    assert torch.load(tmp_path / "model_3.pt", weights_only=True)["infos"][SCORE_KEY] == 0.5
    # a resumed run's runner knows no scores: it reads 3's 0.5 from the file
    resumed = runner_of(keep=2)
    save_at(resumed, 6, 0.45)
    assert names(tmp_path) == ["model_3.pt", "model_5.pt", "model_6.pt"]
    save_at(resumed, 7, 0.9)
    assert names(tmp_path) == ["model_6.pt", "model_7.pt"]


def iterations_logged(path: Path) -> set[int]:
    with open(path, "rb") as f:
        return {json.loads(m.data)["iteration"] for _, _, m in make_reader(f).iter_messages()}


@pytest.mark.slow
def test_a_run_keeping_2_checkpoints_leaves_the_last_2_and_resumes_from_them(run_cli, tmp_path):
    # smoke episodes last 1 s, too short to push the object to its subgoal: every success rate is 0 (or not yet
    # defined), so the best is the newest and exactly the last 2 of 4 checkpoints (save_interval 1) stay
    proc = run_cli(
        ["train", "debug=smoke", "train.iterations=4", "algo.keep_checkpoints=2", "train.run_root=."], tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    run_dir = tmp_path / proc.stdout.strip().splitlines()[-1]
    assert names(run_dir) == ["model_2.pt", "model_3.pt"]
    (run_dir / POLICY_FILE).unlink()  # as if cut after its last checkpoint: resume to 6 iterations
    proc = run_cli(["train", "--resume", run_dir, "train.iterations=6"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert names(run_dir) == ["model_4.pt", "model_5.pt"]
    assert torch.load(run_dir / "model_5.pt", weights_only=True)["iter"] == 5
    assert iterations_logged(run_dir / "metrics.1.mcap") == {4, 5}  # continued from model_3, not from scratch
    assert (run_dir / POLICY_FILE).is_file() and (run_dir / ONNX_FILE).is_file()
