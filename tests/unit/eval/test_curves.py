"""Learning curves: which checkpoints a curve takes, and that points drawn before are read, not drawn again."""

from __future__ import annotations

from mapush.eval import curves

# 500 envs x 24 steps: 12,000 env-steps an iteration (model_k.pt holds k + 1 iterations)
CFG = {"num_envs": 500, "algo": {"num_steps_per_env": 24}, "level": {"name": "mid"}}


def _run(tmp_path, iterations):
    for k in iterations:
        (tmp_path / f"model_{k}.pt").write_bytes(b"")
    return tmp_path


def _drawing(monkeypatch):
    """Record the checkpoints evaluated; each point's success is its iteration / 1000."""
    evaluated = []

    def evaluate(cfg, checkpoint, episodes, seeds):
        evaluated.append(checkpoint.name)
        k = int(checkpoint.stem.split("_")[1])
        return {"success_rate": k / 1000, "success_rate_std": 0.0, "completion_time": 1.0}

    monkeypatch.setattr(curves, "evaluate_quietly", evaluate)
    return evaluated


def test_a_curve_takes_the_last_checkpoint_before_every_mark_and_the_last(tmp_path):
    run = _run(tmp_path, [0, 50, 100, 150, 166, 200, 249])
    # marks every 2M env-steps: model_165 would hold 2.0M; model_166 holds 2.004M, past the first mark
    assert [p.name for p in curves.curve_checkpoints(run, CFG, 2.0e6)] == ["model_150.pt", "model_249.pt"]


def test_points_drawn_before_are_kept_and_only_the_new_checkpoints_drawn(tmp_path, monkeypatch):
    evaluated = _drawing(monkeypatch)
    run = _run(tmp_path, [49, 99, 149])
    shorter = curves.learning_curve(run, CFG, 6.0e5, 200, [0])  # marks at 50, 100, 150 iterations
    assert evaluated == ["model_49.pt", "model_99.pt", "model_149.pt"]
    shorter[0]["success_rate"] = 0.5  # as read from the file: kept as it is
    evaluated.clear()
    _run(tmp_path, [199, 249])  # trained on
    longer = curves.learning_curve(run, CFG, 6.0e5, 200, [0], drawn=shorter)
    assert evaluated == ["model_199.pt", "model_249.pt"]
    assert [p["iteration"] for p in longer] == [49, 99, 149, 199, 249]
    assert [p["success_rate"] for p in longer] == [0.5, 0.099, 0.149, 0.199, 0.249]
    assert longer[-1]["env_steps"] == 250 * 12_000


def test_a_point_at_a_checkpoint_the_curve_no_longer_takes_is_dropped(tmp_path, monkeypatch):
    evaluated = _drawing(monkeypatch)
    run = _run(tmp_path, [49, 60])
    drawn = [{"iteration": 60, "env_steps": 61 * 12_000, "success_rate": 0.9}]  # the shorter run's last checkpoint
    _run(tmp_path, [99])
    points = curves.learning_curve(run, CFG, 6.0e5, 200, [0], drawn=drawn)
    assert [p["iteration"] for p in points] == [49, 99] and evaluated == ["model_49.pt", "model_99.pt"]
