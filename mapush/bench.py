"""`mapush bench`: env, raw-physics and training throughput plus peak memory, measured in one run.

One env-step is one 50 Hz control step of one env with all its robots (architecture section 7). The raw figure
steps the same `mujoco.batch` with random controls and no env logic: the physical limit on this machine. The two
are timed alternately, best round of each, so that drift on a shared machine hits both alike.
"""

from __future__ import annotations

import os
import platform
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from omegaconf import DictConfig

from mapush.config import to_plain
from mapush.envs.mid import MidPushEnv

ROUNDS = 3


def _time_env(env: MidPushEnv, steps: int, gen: torch.Generator) -> float:
    actions = torch.rand(steps, env.num_envs, env.num_agents, env.num_actions, generator=gen) * 2 - 1
    start = time.perf_counter()
    for k in range(steps):
        env.step(actions[k])
    return env.num_envs * steps / (time.perf_counter() - start)


def _time_raw(env: MidPushEnv, steps: int, rng: np.random.Generator) -> float:
    sim = env.sim
    controls = rng.uniform(-0.5, 0.5, (steps, *sim.ctrl.shape))
    start = time.perf_counter()
    for k in range(steps):
        sim.ctrl[:] = controls[k]
        sim.batch.step(nstep=sim.decimation)
    return env.num_envs * steps / (time.perf_counter() - start)


def _time_training(cfg: dict, iterations: int) -> tuple[float, float]:
    """Training env-steps/s without any logging and with all of it, timed alternately; best round of each.

    "All of it" is the heaviest setting: `metrics.mcap` with its per-iteration flush, the progress line, rsl-rl's
    console report to `train.log`, and env 0's every episode recorded to an episode file.
    """
    from mapush.rl.runner import learn
    from mapush.train import attach_episode_recorder, build

    steps = iterations * cfg["algo"]["num_steps_per_env"] * cfg["num_envs"]
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = Path(tmp)
        _, plain = build(cfg, None, iterations)
        env, logged = build({**cfg, "train": {**cfg["train"], "progress": False}}, run_dir, iterations)
        recorder = attach_episode_recorder(cfg, env, run_dir / "episodes.mcap", every_steps=1)
        plain.learn(1)  # warm-up: allocations, first normalizer updates
        learn(logged, 1, run_dir / "train.log")
        plain_rates, logged_rates = [], []
        for _ in range(ROUNDS):
            start = time.perf_counter()
            plain.learn(iterations)
            plain_rates.append(steps / (time.perf_counter() - start))
            start = time.perf_counter()
            learn(logged, iterations, run_dir / "train.log")
            logged_rates.append(steps / (time.perf_counter() - start))
        recorder.close()
    return max(plain_rates), max(logged_rates)


def run_bench(cfg: DictConfig) -> dict:
    """Run every measurement of the benchmark; returns the figures (also the `--json` content)."""
    plain = to_plain(cfg)
    plain["num_envs"] = int(cfg.bench.num_envs)
    steps = int(cfg.bench.steps)
    env = MidPushEnv(plain)
    gen, rng = torch.Generator().manual_seed(0), np.random.default_rng(0)
    _time_env(env, 10, gen)
    env_rates, raw_rates = [], []
    for _ in range(ROUNDS):
        raw_rates.append(_time_raw(env, steps, rng))
        env_rates.append(_time_env(env, steps, gen))
    del env
    train_rate, logged_rate = _time_training(plain, int(cfg.bench.train_iterations))
    env_best, raw_best = max(env_rates), max(raw_rates)
    return {
        "task": cfg.task.name,
        "num_envs": plain["num_envs"],
        "num_agents": int(cfg.task.num_agents),
        "lowlevel": cfg.lowlevel.name,
        "steps": steps,
        "env_steps_per_s": round(env_best),
        "raw_sim_steps_per_s": round(raw_best),
        "env_to_raw_ratio": round(env_best / raw_best, 3),
        "train_steps_per_s": round(train_rate),
        "train_steps_per_s_logged": round(logged_rate),
        "logging_overhead": round(1 - logged_rate / train_rate, 3),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "cores": os.cpu_count(),
        "torch_threads": torch.get_num_threads(),
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}",
    }
