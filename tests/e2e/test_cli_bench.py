"""`mapush bench`: it runs and reports its figures (the figures themselves are never asserted), its iteration
breakdown accounts for the iteration, `--learn` finds when thresholds are first reached, and `--video` renders."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import pytest
from stand_ins import assert_bad_input

from mapush.bench.learning import checkpoint_marks
from mapush.bench.throughput import iteration_breakdown
from mapush.eval.curve_points import first_reaching
from mapush.eval.curves import env_steps_at


@pytest.mark.slow
def test_bench_writes_its_figures_as_json_and_no_run_dir(cli, tmp_path):
    out = tmp_path / "bench.json"
    proc = cli("bench", "debug=smoke", "--json", out)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    assert json.loads(proc.stdout) == result
    # smoke: 8 envs x 2 agents on the cuboid, 5 timed steps
    assert (result["task"], result["num_envs"], result["num_agents"], result["steps"]) == ("cuboid", 8, 2, 5)
    for key in ("env_steps_per_s", "raw_sim_steps_per_s", "train_steps_per_s", "peak_rss_mb"):
        assert result[key] > 0
    assert set(result["iteration"]["phases_ms"]) >= {"physics", "env logic", "policy inference", "ppo update"}
    assert not (tmp_path / "runs").exists()


def test_the_iteration_breakdown_adds_up_to_the_iteration_time(cfg_for):
    from mapush.levels import build

    cfg = cfg_for("debug=smoke", "num_envs=32", "algo.num_steps_per_env=16", "log.episode_interval=0")
    with tempfile.TemporaryDirectory() as tmp:
        env, runner = build(cfg, Path(tmp), 6)
        out = iteration_breakdown(env, runner, 6, Path(tmp) / "train.log")
    phases = out["phases_ms"]
    assert all(v >= 0 for v in phases.values()), phases
    assert phases["physics"] > 0 and phases["ppo update"] > 0 and phases["logging"] > 0
    # the phases are disjoint parts of the iteration (no timing bound: the machine may be shared)
    assert sum(phases.values()) <= out["iteration_ms"] + 0.01 * len(phases), out  # each rounded to 0.01 ms
    assert abs(sum(out["phases_share"].values()) - out["accounted"]) < 1e-3 and 0 < out["accounted"] <= 1.001


def test_env_steps_count_every_env_and_control_step(cfg_for):
    cfg = cfg_for()  # 500 envs x 24 steps per iteration
    assert env_steps_at(cfg, 0) == 12_000
    assert env_steps_at(cfg, 9) == 120_000
    cfg["level"]["decision_steps"] = 25  # a high-level decision holds 25 control steps
    assert env_steps_at(cfg, 0) == 300_000


def _points(*rates: float) -> list[dict]:
    return [
        {"minutes": 0.5 * (k + 1), "env_steps": 1000 * (k + 1), "iteration": 10 * k, "success_rate": r}
        for k, r in enumerate(rates)
    ]


def test_first_reaching_is_the_first_evaluation_at_or_above_the_threshold():
    points = _points(0.2, 0.61, 0.55, 0.8, 0.9)
    assert first_reaching(points, 0.6) == {"minutes": 1.0, "env_steps": 2000, "iteration": 10}
    assert first_reaching(points, 0.8) == {"minutes": 2.0, "env_steps": 4000, "iteration": 30}
    assert first_reaching(points, 0.95) is None
    # a float32 mean of 60 successes in 100 trials reaches 60 %
    assert first_reaching(_points(0.5, 0.59999996), 0.6) == {"minutes": 1.0, "env_steps": 2000, "iteration": 10}


def test_each_mark_takes_the_last_checkpoint_written_before_it(tmp_path):
    launched = 1_000_000.0
    written_at_s = {0: 20, 10: 50, 20: 80, 30: 100, 40: 170}  # iteration -> seconds after launch
    for iteration, seconds in written_at_s.items():
        path = tmp_path / f"model_{iteration}.pt"
        path.write_bytes(b"")
        os.utime(path, (launched + seconds, launched + seconds))
    marks = checkpoint_marks(tmp_path, launched, every_min=1.0)
    # 1 min: model_10 (50 s); 2 min: model_30 (100 s); 3 min: model_40 (170 s)
    assert [(round(m, 4), p.name) for m, p in marks] == [
        (round(50 / 60, 4), "model_10.pt"),
        (round(100 / 60, 4), "model_30.pt"),
        (round(170 / 60, 4), "model_40.pt"),
    ]


@pytest.mark.slow
def test_bench_learn_trains_evaluates_and_draws_its_curve(cli, tmp_path):
    out = tmp_path / "learn" / "smoke.json"
    # A checkpoint every iteration and a whole minute: start-up on a loaded 2-core machine took more than 12 s.
    learn = ["bench.learn.eval_every_min=0.5", "bench.learn.save_interval=1"]
    proc = cli("bench", "--learn", "--minutes", "1", "debug=smoke", *learn, "--json", out)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    assert out.with_suffix(".png").is_file()
    assert result["task"] == "cuboid" and set(result["reached"]) == {"0.6", "0.7", "0.8"}
    minutes = [p["minutes"] for p in result["points"]]
    assert minutes == sorted(minutes) and 0 < minutes[-1] <= 1 + 0.05
    assert (tmp_path / result["run_dir"]).is_dir()


@pytest.mark.slow
def test_bench_learn_says_so_when_no_checkpoint_came_in_time(cli):
    proc = cli("bench", "--learn", "--minutes", "0.01", "debug=smoke")  # 0.6 s: less than importing torch
    assert proc.returncode == 2 and "--minutes 0.01: no checkpoint was written in that time" in proc.stderr


@pytest.mark.slow
def test_bench_learn_refuses_a_non_positive_time(cli, tmp_path):
    proc = cli("bench", "--learn", "--minutes", "0", "debug=smoke")
    assert proc.returncode == 2 and "--minutes 0.0 must be positive" in proc.stderr
    assert not (tmp_path / "runs").exists()


def test_bench_video_refuses_learn_at_once(cli, tmp_path):
    assert_bad_input(cli("bench", "--video", "--learn"), "--video and --learn", "valid: one of them")
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_bench_video_renders_encodes_and_reports_its_times(cli, tmp_path):
    pytest.importorskip("av")
    out, figures = tmp_path / "bench.mp4", tmp_path / "figures" / "bench.json"
    short = ["level.episode_length_s=2", "log.video.width=320"]  # shipped:cuboid's episode, cut to a 2 s timeout
    proc = cli("bench", "--video", "--out", out, "--json", figures, *short)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(figures.read_text())
    assert json.loads(proc.stdout) == result
    assert (result["target"], result["episode_s"], result["width"]) == ("shipped:cuboid", 2.0, 320)
    fps, speedup = result["frame_every_s"] ** -1, result["speedup"]  # today's defaults, as the bench reports them
    assert (result["frames"], result["video_duration_s"]) == (round(2 * fps), pytest.approx(2 / speedup))
    assert result["wall_s"] >= result["video_s"] > 0 and out.stat().st_size > 0
    assert result["command"].startswith("mapush bench --video")
