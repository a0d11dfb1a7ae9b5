"""The levels mapush can train and evaluate, and the one place that builds a level's env and PPO runner.

`train`, `eval`, `bench` and the experiments build through here; nothing below this layer knows the registry.
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig

from mapush.config import sim_threads, to_plain
from mapush.envs.high import HighPushEnv
from mapush.envs.locomotion import TRACKING_ERRORS, LocomotionEnv
from mapush.envs.locomotion_events import locomotion_model
from mapush.envs.mid import MidPushEnv
from mapush.envs.mid_long import LongMidPushEnv
from mapush.envs.nav_high import NavHighPushEnv
from mapush.envs.observations import agents_for_local_dim
from mapush.envs.resets import make_planner
from mapush.errors import BadInput
from mapush.logging.foxglove_scene import SceneLayout
from mapush.logging.go1_scene import Go1Layout
from mapush.rl.frozen import load_mid_policy
from mapush.rl.policy import actor_shape, read_checkpoint
from mapush.rl.runner import MapushRunner, load_checkpoint, obs_width, seed_everything, train_cfg_for
from mapush.rl.vecenv import AgentRowsVecEnv
from mapush.rundir import resolve_checkpoint
from mapush.schema import check_config


@dataclass(frozen=True)
class Level:
    """A trainable level: its env class, what `make_env` must hand it besides the config, and what evaluation and
    checkpoint loading need to know of it (so that neither asks which level it holds)."""

    env: type
    layout: Callable[[dict], object] = SceneLayout.from_config  # what episode logs draw of a config's scene
    frozen_mid: bool = False  # drives the robots through a frozen mid level (`mid=RUN_DIR`, `frozen_mid_level`)
    planner: bool = False  # plans reference paths with OMPL (`level.path.plan_at_eval`, `plan_in_training`)
    walks_robots: bool = True  # its robots are walked by a low level, whose locomotion policy an eval records
    tracking: tuple[str, ...] = ()  # per-episode tracking errors its episodes end with; with them, its exception
    # rate is reported as its `fall_rate` (the locomotion level)
    width_hint: Callable[[int], str] | None = None  # what a checkpoint's observation width says of its config


def agents_hint(width: int) -> str:
    """The agent count a mid-level observation of `width` is made for, as an override to try."""
    return f"task.num_agents={agents_for_local_dim(width)}"


def go1_layout(cfg: dict) -> Go1Layout:
    """What the low level's episode logs draw: the Go1's geoms."""
    return Go1Layout.from_model(locomotion_model(cfg))


LEVELS = {
    "locomotion": Level(LocomotionEnv, layout=go1_layout, walks_robots=False, tracking=TRACKING_ERRORS),
    "mid": Level(MidPushEnv, width_hint=agents_hint),
    "mid_long": Level(LongMidPushEnv),
    "high": Level(HighPushEnv, frozen_mid=True, planner=True),
    "high_nav": Level(NavHighPushEnv, planner=True),
}
"""The trainable levels, by `level.name`."""


def level_of(cfg: dict) -> Level:
    """The level of a config; BadInput for a level that cannot be trained."""
    name = cfg["level"]["name"]
    if name not in LEVELS:
        raise BadInput(f"level {name!r} cannot be trained yet; valid: {', '.join(LEVELS)}")
    return LEVELS[name]


def scene_layout(cfg: dict):
    """What the episode logs of a config's level draw: the arena, object and robots (`SceneLayout`), or the Go1."""
    return level_of(cfg).layout(cfg)


def env_class(cfg: dict) -> type:
    """The env class of a config's level; BadInput for a level that cannot be trained."""
    return level_of(cfg).env


def checked(cfg: DictConfig) -> dict:
    """`cfg` checked as every command checks a config before it builds or writes anything: value types and ranges
    (`schema`), the level's own checks, and a high level's frozen mid level (made absolute in `cfg`, so that a run
    finds it from anywhere). Returns it as a plain dict; BadInput for a mistake."""
    check_config(cfg)
    plain = to_plain(cfg)
    level = level_of(plain)
    level.env.validate(plain)
    if level.frozen_mid:
        if cfg.mid:
            cfg.mid = plain["mid"] = str(Path(cfg.mid).resolve())
        frozen_mid_level(plain)
    if plain["train"]["init_from"]:
        cfg.train.init_from = plain["train"]["init_from"] = str(_init_weights(plain))
    return plain


def _init_weights(cfg: dict) -> Path:
    """The checkpoint `train.init_from` names, absolute, checked to fit the config's observations (BadInput)."""
    _, checkpoint = resolve_checkpoint(Path(cfg["train"]["init_from"]))
    trained, _ = actor_shape(read_checkpoint(checkpoint))
    width = make_env({**cfg, "num_envs": 1}).observations()["policy"].shape[-1]
    if trained != width:
        raise BadInput(
            f"train.init_from {str(checkpoint)!r} expects a {trained}-d observation but the config gives {width}-d; "
            "valid: a run of the same level, task and agent count"
        )
    return checkpoint.resolve()


def frozen_mid_level(cfg: dict):
    """The frozen mid level a high-level config drives (`mid`), checked to fit its task; loaded once, though
    `checked` and `make_env` both ask for it (again when the run dir or checkpoint has changed since)."""
    path = str(cfg["mid"])
    changed = Path(path).stat().st_mtime_ns if path and Path(path).exists() else None
    return _frozen(path, changed, cfg["task"]["name"], int(cfg["task"]["num_agents"]))


@functools.lru_cache(maxsize=4)
def _frozen(path: str, changed: int | None, task: str, agents: int):
    return load_mid_policy(path, {"name": task, "num_agents": agents}, level="mid")


def make_env(cfg: dict, evaluation: bool = False):
    """The env of a config. A high level gets its frozen mid level (if it drives one) and an OMPL planner where its
    paths are planned: at evaluation (`path.plan_at_eval`), in training with `path.plan_in_training`."""
    level = level_of(cfg)
    extra = {}
    if level.frozen_mid:
        extra["mid"] = frozen_mid_level(cfg)
    if level.planner and cfg["level"]["path"]["plan_at_eval" if evaluation else "plan_in_training"]:
        extra["planner"] = make_planner(cfg)
    return level.env(cfg, evaluation=evaluation, **extra)


def torch_threads(cfg: dict) -> tuple[int, int]:
    """Torch threads of the rollout and of the PPO update (`train.rollout_threads`, `train.update_threads`);
    0 means as many as MuJoCo steps the batch with (`sim.nthread`, itself 0 for every core)."""
    return tuple(int(cfg["train"][key]) or sim_threads(cfg) for key in ("rollout_threads", "update_threads"))


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
    runner.add_git_repo_to_log(__file__)  # the commit of mapush's checkout, if any
    return env, runner


def build_for_eval(cfg: dict, checkpoint: Path):
    """The env, rsl-rl's vec env over it and the checkpoint's deterministic policy, as `mapush eval` and
    `mapush play` run them; BadInput when the checkpoint does not fit the config."""
    env, runner = build(cfg, None, 0, evaluation=True)
    load_into(runner, cfg, checkpoint, f"task {cfg['task']['name']} with {env.num_agents} agents")
    return env, runner.env, runner.get_inference_policy()


def load_into(runner, cfg: dict, checkpoint: Path, what: str, weights: bool = False) -> int:
    """`load_checkpoint` into a runner of `cfg`'s level, a misfit's message hinting what the checkpoint fits."""
    return load_checkpoint(runner, checkpoint, obs_width(runner), what, weights, hint=level_of(cfg).width_hint)
