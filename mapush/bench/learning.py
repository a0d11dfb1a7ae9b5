"""Time to success: how many minutes (and env-steps) of `mapush train` a level needs to reach given evaluated
success rates on this machine.

The benchmark runs the real `mapush train` as a child process for a fixed wall time, checkpointing every
`bench.learn.save_interval` iterations, then stops it (SIGTERM: logs close, checkpoints are atomic); a killed
benchmark takes it along (`mapush.children`). A checkpoint's time is its file's write time since the launch, so
start-up counts as a user would count it. After training, the last checkpoint before every
`bench.learn.eval_every_min` mark is evaluated as `mapush eval` does (deterministic first episodes,
`eval.episodes` trials x `eval.seeds`), on the otherwise idle machine.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig

from mapush.children import dies_with_parent
from mapush.config import load_run_config, to_plain
from mapush.errors import BadInput
from mapush.eval.curve_points import first_reaching
from mapush.eval.curves import evaluate_points, last_before_marks
from mapush.rundir import checkpoints


def train_for(overrides: list[str], minutes: float, save_interval: int, run_root: Path) -> tuple[Path, float]:
    """Run `mapush train OVERRIDES` for `minutes` of wall time; returns its run dir and launch time (epoch s)."""
    command = [
        sys.executable, "-m", "mapush", "train", *overrides,
        "train.iterations=100000000", f"algo.save_interval={save_interval}", f"train.run_root={run_root}",
        "train.progress=false", "algo.keep_checkpoints=0",  # every checkpoint: the time marks pick among them
    ]  # fmt: skip
    launched = time.time()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, preexec_fn=dies_with_parent())
    run_dir = Path(child.stdout.readline().strip())
    try:
        child.wait(timeout=minutes * 60 - (time.time() - launched))
    except subprocess.TimeoutExpired:
        child.send_signal(signal.SIGTERM)
        child.wait()
    if not (run_dir / "config.yaml").is_file():
        raise BadInput(f"mapush train {' '.join(overrides)} made no run dir (exit {child.returncode})")
    return run_dir, launched


def checkpoint_marks(run_dir: Path, launched: float, every_min: float) -> list[tuple[float, Path]]:
    """(minutes since launch, checkpoint): the last checkpoint written before each mark of `every_min` minutes."""
    found = checkpoints(run_dir)
    minutes = [(p.stat().st_mtime - launched) / 60 for p in found]
    return [(minutes[k], found[k]) for k in last_before_marks(minutes, every_min)]


def recipe(cfg: dict) -> dict:
    """The training settings a time-to-success figure depends on most (the run's config.yaml has them all)."""
    algo = cfg["algo"]
    return {
        "num_envs": cfg["num_envs"],
        "num_steps_per_env": algo["num_steps_per_env"],
        "hidden_dims": {"actor": algo["actor"]["hidden_dims"], "critic": algo["critic"]["hidden_dims"]},
        "epochs": algo["algorithm"]["num_learning_epochs"],
        "mini_batches": algo["algorithm"]["num_mini_batches"],
        "desired_kl": algo["algorithm"].get("desired_kl"),
        "threads": {"rollout": cfg["train"].get("rollout_threads"), "update": cfg["train"].get("update_threads")},
    }


def run_learning_bench(cfg: DictConfig, overrides: list[str], minutes: float, run_root: Path) -> dict:
    """Train for `minutes`, evaluate the checkpoints along the way, and report when each threshold was reached."""
    learn = cfg.bench.learn
    run_dir, launched = train_for(overrides, minutes, int(learn.save_interval), run_root)
    run_cfg = to_plain(load_run_config(run_dir))
    marks = checkpoint_marks(run_dir, launched, float(learn.eval_every_min))
    if not marks:
        raise BadInput(
            f"--minutes {minutes:g}: no checkpoint was written in that time (start-up and "
            f"bench.learn.save_interval={int(learn.save_interval)} iterations took longer); valid: more minutes or a "
            "smaller save_interval"
        )
    points = []
    episodes, seeds = int(run_cfg["eval"]["episodes"]), list(run_cfg["eval"]["seeds"])
    for at_min, checkpoint in marks:
        point = {"minutes": round(at_min, 3), **evaluate_points(run_cfg, [checkpoint], episodes, seeds)[0]}
        points.append(point)
        print(
            f"{at_min:5.2f} min  it {point['iteration']:5d}  success {100 * point['success_rate']:5.1f} %",
            file=sys.stderr,
        )
    return {
        "level": run_cfg["level"]["name"],
        "task": run_cfg["task"]["name"],
        "num_agents": run_cfg["task"]["num_agents"],
        "overrides": list(overrides),
        "recipe": recipe(run_cfg),
        "commit": json.loads((run_dir / "meta.json").read_text())["commit"],
        "run_dir": str(run_dir),
        "train_minutes": minutes,
        "episodes": int(run_cfg["eval"]["episodes"]),
        "seeds": list(run_cfg["eval"]["seeds"]),
        "cores": os.cpu_count(),
        "reached": {f"{t:g}": first_reaching(points, t) for t in learn.thresholds},
        "points": points,
    }


def plot_learning(result: dict, png: Path) -> None:
    """Evaluated success (mean +- std over eval seeds) against minutes and against env-steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = result["points"]
    sr = np.array([p["success_rate"] for p in points]) * 100
    std = np.array([p["success_rate_std"] for p in points]) * 100
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    for ax, key, label in ((axes[0], "minutes", "wall time (min)"), (axes[1], "env_steps", "env-steps (M)")):
        x = np.array([p[key] for p in points], dtype=float) / (1e6 if key == "env_steps" else 1)
        ax.plot(x, sr, marker="o", ms=3)
        ax.fill_between(x, sr - std, sr + std, alpha=0.25)
        for threshold in result["reached"]:
            ax.axhline(100 * float(threshold), color="grey", lw=0.6, ls="--")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("evaluated success (%)")
    fig.suptitle(
        f"{result['level']} level, {result['task']}, {result['num_agents']} robots "
        f"({result['cores']} cores; {result['episodes']} trials x {len(result['seeds'])} seeds)"
    )
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
