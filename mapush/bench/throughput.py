"""Throughput of any level: env, raw physics and training env-steps/s, where a PPO iteration's time goes, memory.

One env-step is one 50 Hz control step of one env with all its robots (docs/performance.md); a high-level
decision holds `level.decision_steps` of them. The raw figure steps the same `mujoco.batch` under the controls the
env's own timed run applied, replayed without the env: the same physics work (robots walking, pushing, touching)
with nothing around it, the limit on this machine. (Random controls would be cheaper physics than the env's: robots
that touch nothing.) The env runs on the rollout's torch threads (`train.rollout_threads`), as training runs it.
Env and raw are timed alternately, best round of each, so drift on a shared machine hits both alike.
"""

from __future__ import annotations

import functools
import os
import platform
import resource
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch
from omegaconf import DictConfig

from mapush.config import to_plain
from mapush.levels import build, make_env, torch_threads
from mapush.rl.runner import learn
from mapush.training import attach_episode_recorder

ROUNDS = 3


def _time_env(env, steps: int, gen: torch.Generator) -> tuple[float, list[np.ndarray]]:
    """Env-steps/s of `steps` env steps with seeded random actions, and the controls its physics ran with (one
    array per physics call, copied as `BatchSim.advance` is called)."""
    shape = (steps, env.num_envs, env.policy_agents, env.num_actions)
    actions = torch.rand(*shape, generator=gen) * 2 - 1
    sim, controls = env.sim, []
    advance = sim.advance

    def recorded(substep=None) -> np.ndarray:
        controls.append(sim.ctrl.copy())
        return advance(substep)

    sim.advance = recorded
    try:
        start = time.perf_counter()
        for k in range(steps):
            env.step(actions[k])
        elapsed = time.perf_counter() - start
    finally:
        del sim.advance  # the class's method again
    return env.num_envs * steps * _control_steps(env) / elapsed, controls


def _time_raw(env, controls: list[np.ndarray]) -> float:
    """Env-steps/s of raw `mujoco.batch` stepping of the env's batch under the controls the env ran with: the same
    physics work (robots walking and pushing) without the env's logic, policies or resets."""
    sim = env.sim  # every level's `BatchSim`
    start = time.perf_counter()
    for ctrl in controls:
        sim.ctrl[:] = ctrl
        sim.batch.step(nstep=sim.decimation)
    return env.num_envs * len(controls) / (time.perf_counter() - start)


def _control_steps(env) -> int:
    """50 Hz control steps in one step of `env` (a high-level decision holds several)."""
    return int(getattr(env, "decision_steps", 1))


class PhaseClock:
    """Accumulates wall time of named phases by wrapping bound methods of live objects (`watch`)."""

    def __init__(self):
        self.seconds: dict[str, float] = defaultdict(float)

    def watch(self, owner, method: str, phase: str) -> None:
        inner = getattr(owner, method)

        @functools.wraps(inner)
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds[phase] += time.perf_counter() - start

        setattr(owner, method, timed)


def iteration_breakdown(env, runner, iterations: int, log_path: Path) -> dict:
    """Time `iterations` PPO iterations of `runner` (with its logging) and split each into phases.

    The rollout splits into physics, the low level's commands (the Go1's locomotion
    policy), the frozen mid level (high levels), the rest of the env's step (observations, rewards, terminations,
    resets, recorders), policy inference, and bookkeeping (what remains of the rollout: rows, NaN checks,
    the rollout storage). The update is the returns and the PPO epochs; logging is the logger's
    per-step and per-iteration work, opening and closing its writer, and checkpoint writes. Returns ms per
    iteration and shares of the measured iteration time; `accounted` is the sum of the phases over that time
    (1.0 = nothing missed).
    """
    clock = PhaseClock()
    clock.watch(env.sim.batch, "step", "physics")
    if hasattr(env.sim, "lowlevel"):
        clock.watch(env.sim.lowlevel, "command", "low level")
    if getattr(env, "mid", None) is not None:
        clock.watch(env.mid, "commands", "frozen mid level")
    clock.watch(env, "step", "env step")
    clock.watch(runner.alg, "act", "policy inference")
    clock.watch(runner.logger, "process_env_step", "logging (per step)")
    clock.watch(runner, "save", "checkpoints")
    clock.watch(runner.logger, "init_logging_writer", "logging (writer open and close)")
    clock.watch(runner.logger, "stop_logging_writer", "logging (writer open and close)")
    clock.watch(runner.logger, "log", "logging (per iteration)")
    # rsl-rl times its rollout and update on the wall clock (time.time), which a fresh machine's clock sync may step;
    # here every phase is on perf_counter: an iteration starts when the writer opens or the previous iteration's
    # log (or checkpoint) returns, its rollout ends where the returns are computed
    iteration_start = [0.0]

    def starts_iteration(owner, method: str) -> None:
        inner = getattr(owner, method)

        @functools.wraps(inner)
        def then_restart(*args, **kwargs):
            try:
                return inner(*args, **kwargs)
            finally:
                iteration_start[0] = time.perf_counter()

        setattr(owner, method, then_restart)

    for owner, method in ((runner.logger, "init_logging_writer"), (runner.logger, "log"), (runner, "save")):
        starts_iteration(owner, method)
    clock.watch(runner.alg, "compute_returns", "ppo update")
    returns = runner.alg.compute_returns

    @functools.wraps(returns)
    def ends_rollout(*args, **kwargs):
        clock.seconds["rollout"] += time.perf_counter() - iteration_start[0]
        return returns(*args, **kwargs)

    runner.alg.compute_returns = ends_rollout
    clock.watch(runner.alg, "update", "ppo update")
    start = time.perf_counter()
    learn(runner, iterations, log_path)
    total = time.perf_counter() - start
    s = clock.seconds
    inside_env = s["physics"] + s["low level"] + s["frozen mid level"]
    phases = {
        "physics": s["physics"],
        "low level": s["low level"],
        "frozen mid level": s["frozen mid level"],
        "env logic": s["env step"] - inside_env,
        "policy inference": s["policy inference"],
        "rollout bookkeeping": s["rollout"] - s["env step"] - s["policy inference"] - s["logging (per step)"],
        "ppo update": s["ppo update"],
        "logging": sum(v for k, v in s.items() if k.startswith("logging")) + s["checkpoints"],
    }
    return {
        "iteration_ms": round(1000 * total / iterations, 2),
        "phases_ms": {k: round(1000 * v / iterations, 2) for k, v in phases.items()},
        "phases_share": {k: round(v / total, 4) for k, v in phases.items()},
        "accounted": round(sum(phases.values()) / total, 4),
    }


def _time_training(cfg: dict, iterations: int, control_steps: int) -> dict:
    """Training env-steps/s without any logging and with all of it (best rounds, timed alternately), and the
    phases of an iteration with all logging on.

    "All of it" is the heaviest setting: `metrics.mcap` with its per-iteration flush, the progress line, rsl-rl's
    console report to `train.log`, and env 0's every episode recorded to an episode file.
    """
    steps = iterations * cfg["algo"]["num_steps_per_env"] * cfg["num_envs"] * control_steps
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
        breakdown = iteration_breakdown(env, logged, iterations, run_dir / "train.log")
        recorder.close()
    return {"plain": max(plain_rates), "logged": max(logged_rates), "breakdown": breakdown}


def run_bench(cfg: DictConfig) -> dict:
    """Run every measurement of the benchmark for the config's level; returns the figures (the `--json` content)."""
    plain = to_plain(cfg)
    plain["num_envs"] = int(cfg.bench.num_envs)
    steps = int(cfg.bench.steps)
    env = make_env(plain)
    gen = torch.Generator().manual_seed(0)
    threads = torch.get_num_threads()
    torch.set_num_threads(torch_threads(plain)[0])  # the env as training's rollout runs it (`MapushRunner`)
    try:
        _time_env(env, 2, gen)
        env_rates, raw_rates = [], []
        for _ in range(ROUNDS):
            rate, controls = _time_env(env, steps, gen)
            env_rates.append(rate)
            raw_rates.append(_time_raw(env, controls))
    finally:
        torch.set_num_threads(threads)
    control_steps = _control_steps(env)
    del env
    training = _time_training(plain, int(cfg.bench.train_iterations), control_steps)
    env_best, raw_best = max(env_rates), max(raw_rates)
    result = {
        "level": cfg.level.name,
        "task": cfg.task.name,
        "num_envs": plain["num_envs"],
        "num_agents": int(cfg.task.num_agents),
        "lowlevel": cfg.lowlevel.name,
        "steps": steps,
        "env_steps_per_s": round(env_best),
        "raw_sim_steps_per_s": round(raw_best),
        "env_to_raw_ratio": round(env_best / raw_best, 3),
        "train_steps_per_s": round(training["plain"]),
        "train_to_raw_ratio": round(training["plain"] / raw_best, 3),
        "train_steps_per_s_logged": round(training["logged"]),
        "logging_overhead": round(1 - training["logged"] / training["plain"], 3),
        "iteration": training["breakdown"],
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "cores": os.cpu_count(),
        "torch_threads": dict(zip(("rollout", "update"), torch_threads(plain), strict=True)),
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}",
    }
    if control_steps > 1:
        result["train_decisions_per_s"] = round(training["plain"] / control_steps)
    return result
