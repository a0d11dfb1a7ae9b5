"""`mapush train`: compose, make (or reopen) a run dir, train with rsl-rl PPO, export the policy."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from pathlib import Path

from omegaconf import DictConfig

import mapush
from mapush.config import check_run_values, load_run_config, new_run_dir, save_run_config, to_plain
from mapush.envs.high import HighPushEnv
from mapush.envs.low import LocomotionEnv
from mapush.envs.mid import MidPushEnv
from mapush.envs.mid_long import LongMidPushEnv
from mapush.envs.nav_high import NavHighPushEnv
from mapush.errors import BadInput
from mapush.logging.episodes import EpisodeRecorder
from mapush.logging.mcap_files import repair_in_place
from mapush.logging.metrics import next_free_path
from mapush.plan import make_planner
from mapush.rl.frozen import load_mid_policy
from mapush.rl.runner import (
    MapushRunner,
    checkpoint_iteration,
    checkpoints,
    export_policy,
    learn,
    load_checkpoint,
    obs_width,
    seed_everything,
    train_cfg_for,
)
from mapush.rl.vecenv import AgentRowsVecEnv

TRAIN_EPISODES = "train_episodes.mcap"


def exit_on_sigterm() -> None:
    """Turn SIGTERM into SystemExit so that `finally` blocks close the MCAP file (libraries.md 3.5)."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


LEVELS = {
    "low": LocomotionEnv,
    "mid": MidPushEnv,
    "mid_long": LongMidPushEnv,
    "high": HighPushEnv,
    "high_nav": NavHighPushEnv,
}
"""The env class of each trainable level."""


def env_class(cfg: dict) -> type:
    """The env class of a config's level; BadInput for a level that cannot be trained."""
    name = cfg["level"]["name"]
    if name not in LEVELS:
        raise BadInput(f"level {name!r} cannot be trained yet; valid: {', '.join(LEVELS)}")
    return LEVELS[name]


def make_env(cfg: dict, evaluation: bool = False):
    """The env of a config. The high levels load their frozen mid level (if they drive one) and an OMPL planner
    where their paths are planned: at evaluation (`path.plan_at_eval`), in training with `path.plan_in_training`."""
    cls = env_class(cfg)
    if cls is LocomotionEnv:
        return cls(cfg, evaluation=evaluation)
    if not issubclass(cls, HighPushEnv):
        return cls(cfg)
    mid = load_mid_policy(cfg["mid"], cfg["task"]) if cls.needs_mid else None
    path = cfg["level"]["path"]
    planner = make_planner(cfg) if path["plan_at_eval" if evaluation else "plan_in_training"] else None
    return cls(cfg, mid, planner=planner)


def torch_threads(cfg: dict) -> tuple[int, int]:
    """Torch threads of the rollout and of the PPO update (`train.rollout_threads`, `train.update_threads`);
    0 means as many as MuJoCo steps the batch with (`sim.nthread`, itself 0 for every core)."""
    sim_threads = int(cfg["sim"]["nthread"]) or os.cpu_count() or 1
    return tuple(int(cfg["train"][key]) or sim_threads for key in ("rollout_threads", "update_threads"))


def build(cfg: dict, run_dir: Path | None, total_iterations: int, evaluation: bool = False):
    """The env and the runner of a config; `run_dir=None` builds them without any logging (evaluation)."""
    seed_everything(int(cfg["seed"]))
    env = make_env(cfg, evaluation)
    vec_env = AgentRowsVecEnv(env, device=cfg["device"])
    # rsl-rl prints the networks on construction: into train.log for a run, nowhere for an evaluation
    sink = open(run_dir / "train.log", "a") if run_dir else open(os.devnull, "w")
    with sink, contextlib.redirect_stdout(sink):
        runner = MapushRunner(
            vec_env,
            train_cfg_for(cfg, env.policy_agents, total_iterations),
            log_dir=str(run_dir) if run_dir else None,
            device=cfg["device"],
            threads=torch_threads(cfg),
        )
    runner.add_git_repo_to_log(mapush.__file__)
    return env, runner


def train(cfg: DictConfig, overrides: list[str], command: str) -> Path:
    """Train a fresh run; returns its run dir."""
    check_run_values(cfg)
    plain = to_plain(cfg)
    cls = env_class(plain)
    cls.validate(plain)
    if getattr(cls, "needs_mid", False):
        if cfg.mid:
            cfg.mid = plain["mid"] = str(Path(cfg.mid).resolve())  # the run must find its mid level from anywhere
        load_mid_policy(plain["mid"], plain["task"])  # fails here, before a run dir exists
    run_dir = new_run_dir(cfg)
    save_run_config(run_dir, cfg, overrides, command)
    print(run_dir, flush=True)
    _run(plain, run_dir)
    return run_dir


def resume(run_dir: Path, iterations: int | None) -> Path:
    """Continue a cut run from its latest checkpoint up to its configured (or the given) iteration count."""
    cfg = load_run_config(run_dir)
    if iterations is not None:
        cfg.train.iterations = iterations
    check_run_values(cfg)
    found = checkpoints(run_dir)
    if not found:
        raise BadInput(f"run dir {str(run_dir)!r} has no checkpoint to resume from; valid: a run with model_*.pt")
    done = checkpoint_iteration(found[-1]) + 1
    if done >= cfg.train.iterations:
        raise BadInput(f"run {str(run_dir)!r} already has {done} iterations; valid: train.iterations=N with N > {done}")
    print(run_dir, flush=True)
    _repair_cut_logs(Path(run_dir))
    _run(to_plain(cfg), Path(run_dir), checkpoint=found[-1])
    return Path(run_dir)


def export_finished(run_dir: Path) -> Path:
    """Export the policy of a run whose last checkpoint holds every iteration (cut while exporting)."""
    cfg = to_plain(load_run_config(run_dir))
    _env, runner = build(cfg, None, int(cfg["train"]["iterations"]))
    load_checkpoint(runner, checkpoints(run_dir)[-1], obs_width(runner), "the run's config")
    export_policy(runner, run_dir)
    return Path(run_dir)


def is_complete(run_dir: Path) -> bool:
    """Whether a run's last checkpoint holds all of its `train.iterations`."""
    found = checkpoints(run_dir)
    return bool(found) and checkpoint_iteration(found[-1]) + 1 >= int(load_run_config(run_dir).train.iterations)


def _run(cfg: dict, run_dir: Path, checkpoint: Path | None = None) -> None:
    """Train `run_dir` up to `train.iterations`, from scratch or from `checkpoint`, then export the policy."""
    exit_on_sigterm()
    total = int(cfg["train"]["iterations"])
    env, runner = build(cfg, run_dir, total)
    done = 0
    if checkpoint is not None:
        done = load_checkpoint(runner, checkpoint, obs_width(runner), "the run's config") + 1
        runner.current_learning_iteration = done  # rsl-rl would repeat the loaded iteration
    interval = int(cfg["log"]["episode_interval"])
    recorder = None
    if interval > 0:
        frames_per_step = round(env.dt / env.frame_dt)  # the high level records every mid-level step
        every_steps = interval * int(cfg["algo"]["num_steps_per_env"]) * frames_per_step
        recorder = attach_episode_recorder(cfg, env, Path(next_free_path(str(run_dir / TRAIN_EPISODES))), every_steps)
    try:
        learn(runner, total - done, run_dir / "train.log")
    finally:
        if recorder is not None:
            recorder.close()
    export_policy(runner, run_dir)


def attach_episode_recorder(cfg: dict, env, path: Path, every_steps: int) -> EpisodeRecorder:
    """Record env 0's next whole episode after every `every_steps` env steps into `path` (training episodes)."""
    recorder = EpisodeRecorder(path, env.scene_layout(cfg), list(env.rewards.terms), env.EXCEPTIONS)
    recorder.watch([0], env.frame_dt, "training", from_start=False, every_steps=every_steps)
    env.recorders.append(recorder)
    return recorder


def _repair_cut_logs(run_dir: Path) -> None:
    """Make the MCAP files a killed run left behind readable again before it continues."""
    for path in sorted(run_dir.glob("*.mcap")):
        try:
            if repair_in_place(path):
                print(f"mapush: recovered the cut log {path}", file=sys.stderr)
        except BadInput as err:
            print(f"mapush: warning: {err}; left as it is", file=sys.stderr)
