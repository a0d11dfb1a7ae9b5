"""`mapush eval`: run deterministic episodes of a checkpoint and write `eval.json` (docs/usage.md).

Each seed runs `episodes` envs in parallel, one episode each (their first), as the original's "calculator" mode;
S.R. is the fraction that succeed, C.T. the time to success with a failure counting as the timeout, normalized
by the timeout (paper IV-B-1). Seeds give the mean +- std.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import torch

from mapush.atomic import locked, remove_leftovers, write_json
from mapush.config import apply_overrides, load_run_config, overrides_name, to_plain
from mapush.envs.base import exception_names
from mapush.envs.events import EVENTS
from mapush.eval.numerics import machine_record
from mapush.levels import build_for_eval, level_of, scene_layout
from mapush.logging.episodes import EpisodeRecorder, LiveView
from mapush.logging.mcap_files import exit_on_sigterm
from mapush.lowlevel import backend_of
from mapush.planning.paths import length as path_length
from mapush.provenance import provenance
from mapush.rewards.manager import RewardManager
from mapush.rundir import PACKAGE, resolve_checkpoint
from mapush.untrusted import run_lock
from mapush.viz.video import eval_video_path, eval_video_recorder

EPISODES = "episodes.mcap"
PROGRESS_STEPS = 50
"""Policy steps between two updates of the progress line."""


def run_episodes(cfg: dict, checkpoint: Path, episodes: int, seed: int, recorders: tuple = ()) -> dict:
    """One episode in each of `episodes` envs with the deterministic policy; per-episode outcomes.

    `recorders` (EpisodeRecorder, LiveView) watch the first envs' episodes.
    """
    cfg = {**cfg, "seed": seed, "num_envs": episodes}
    env, vec, policy = build_for_eval(cfg, checkpoint)
    watched = list(range(max(min(int(cfg["log"]["eval_episodes"]), episodes), 1)))  # the live view follows env 0
    for recorder in recorders:
        recorder.watch(watched, env.frame_dt, f"seed {seed}", from_start=True)
        env.recorders.append(recorder)
    outcomes = first_episodes(env, vec, policy, seed, level_of(cfg).tracking)
    planner = getattr(env, "planner", None)
    if planner is not None and planner.wall_clock_stops:  # plans cut by seconds, not work: machine-dependent
        outcomes["planner_wall_clock_stops"] = planner.wall_clock_stops
        print(
            f"warning: seed {seed}: {planner.wall_clock_stops} plan(s) stopped by level.planner.time_limit_s before "
            "level.planner.max_checks; these episodes may differ on another machine",
            file=sys.stderr,
        )
    return outcomes


def first_episodes(env, vec, policy, seed: int, tracking: tuple[str, ...] = ()) -> dict:
    """Run `policy` (observations -> actions) until every env of `vec` has ended its first episode; outcomes.
    `tracking`: the per-episode tracking errors the level's episodes end with (`Level.tracking`), averaged, and
    then its exception rate is its `fall_rate`."""
    episodes = env.num_envs
    finished = torch.zeros(episodes, dtype=torch.bool)
    success = torch.zeros(episodes, dtype=torch.bool)
    exception = torch.zeros(episodes, dtype=torch.bool)
    planner_failure = torch.zeros(episodes, dtype=torch.bool)
    kind = torch.full((episodes,), -1)  # the exception that ended each failed episode (`env.exception_names`)
    time_s = torch.zeros(episodes)
    errors_of = {name: torch.zeros(episodes) for name in tracking}  # each episode's mean tracking errors
    events_of: dict[str, torch.Tensor] = {}  # each episode's counts (`mapush.envs.events`), where the env counts
    path = getattr(env, "path", None)  # the high levels: the first episodes' reference paths, before any reset
    reference = {"path_length_m": path_length(path).mean().item()} if path is not None else {}
    obs = vec.get_observations()
    show = sys.stderr.isatty()  # a progress line on a terminal; logs and pipes get none
    steps = 0
    with torch.inference_mode():
        while not finished.all():
            obs, _, _, _ = vec.step(policy(obs))
            steps += 1
            if show and steps % PROGRESS_STEPS == 0:
                print(
                    f"\rseed {seed}: {steps * env.dt:.0f} of {env.max_episode_length * env.dt:.0f} s simulated, "
                    f"{int(finished.sum())}/{episodes} episodes ended",
                    end="",
                    file=sys.stderr,
                    flush=True,
                )
            end = vec.last_info["episode_end"]
            first = end["done"] & ~finished
            success |= end["success"] & first
            exception |= end["exception"] & first
            if "planner_failure" in end:
                planner_failure |= end["planner_failure"] & first
            time_s[first] = end["time_s"][first]
            kind[first] = end["exception_kind"][first].long()
            for name, errors in errors_of.items():
                errors[first] = end[name][first]
            for name in EVENTS:
                if name in end:
                    events_of.setdefault(name, torch.zeros(episodes))[first] = end[name][first].float()
            finished |= end["done"]
    if show:
        print("\r\033[K", end="", file=sys.stderr, flush=True)  # clear the progress line
    timeout_s = env.max_episode_length * env.dt
    completion_s = torch.where(success, time_s, torch.full_like(time_s, timeout_s))
    low_level = {name: errors.mean().item() for name, errors in errors_of.items()}
    if tracking:
        low_level["fall_rate"] = exception.float().mean().item()
    events = {name: event_record(counts) for name, counts in events_of.items()}
    return {
        **low_level,
        **reference,
        **({"events": events} if events else {}),
        "seed": seed,
        "episodes": episodes,
        "success_rate": success.float().mean().item(),
        "exception_rate": exception.float().mean().item(),
        "exceptions": {name: (kind == i).float().mean().item() for i, name in enumerate(env.exception_names)},
        "planner_failure_rate": planner_failure.float().mean().item(),
        "completion_time_s": completion_s.mean().item(),
        "completion_time": (completion_s / timeout_s).mean().item(),
        "completion_time_episode_std": (completion_s / timeout_s).std(correction=0).item(),
        "timeout_s": timeout_s,
    }


def event_record(counts: torch.Tensor) -> dict[str, float]:
    """Of one count per episode (E,): the share of episodes where it happened at all, and its mean per episode."""
    return {"episode_share": (counts > 0).float().mean().item(), "per_episode": counts.mean().item()}


def evaluate(
    target: Path,
    episodes: int | None,
    seeds: list[int] | None,
    overrides: list[str] = (),
    live: bool = False,
    name: str = "",
    video: bool = False,
    out_dir: Path | None = None,
    reuse: bool = False,
) -> Path:
    """Evaluate a run dir or checkpoint over seeds; writes and returns `eval.json` in the run dir.

    `overrides` (e.g. `task.num_agents=3`, `lowlevel=tracker`) change the run's config for this evaluation. The
    first `log.eval_episodes` episodes of each seed go to `episodes.mcap`; `live` also streams env 0 to Foxglove
    at real time on 127.0.0.1:`log.live_port`. A `name` keeps several evaluations of one run apart:
    `eval_<name>.json` and `episodes_<name>.mcap`. `video` renders env 0's first episode(s) to `eval_video.mp4`
    (`eval_video_<name>.mp4`; `mapush.viz.video`). Overrides of what is evaluated (all but `log.*`, `eval.*`)
    without a name get one from the overrides, so that they never overwrite the run's own `eval.json`. Files go
    to `out_dir`, by default the run dir (for a policy shipped in the package: `runs/shipped/...`, so that
    nothing is written into the installed package). `reuse` (a sweep's job resumed after a cut) returns the file
    as it is where it already holds this very evaluation (`same_evaluation`) rather than evaluating again.
    """
    run_dir, checkpoint = resolve_checkpoint(target)
    name = name or overrides_name([o for o in overrides if not o.lstrip("+~").startswith(("log.", "eval."))])
    out_dir = Path(out_dir) if out_dir is not None else output_dir(run_dir)
    cfg = to_plain(apply_overrides(load_run_config(run_dir), overrides))
    episodes = episodes or cfg["eval"]["episodes"]
    seeds = seeds if seeds else list(cfg["eval"]["seeds"])
    exit_on_sigterm()
    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / f"eval{_suffix(name)}.json"
    try:
        # a run being trained is refused at once; a second evaluation into this dir waits: no file written twice
        with run_lock(out_dir, training=False), locked(out_dir):
            if reuse and same_evaluation(out, cfg, str(checkpoint), episodes, seeds, overrides):
                return out
            remove_leftovers(out_dir)  # temp files of evaluations that were killed
            per_seed = _record_episodes(cfg, checkpoint, episodes, seeds, out_dir, name, live, video)
            made = summarize(cfg, str(checkpoint), episodes, seeds, per_seed) | {
                "overrides": list(overrides),
                "config_sha256": config_digest(cfg),
            }
            write_json(out, made | provenance())
    except BaseException:
        if created:  # a refused evaluation (another agent count, a bad video setting) leaves nothing behind
            shutil.rmtree(out_dir, ignore_errors=True)
        raise
    return out


def config_digest(cfg: dict) -> str:
    """SHA-256 of an evaluation's composed config, less how it is logged: what a group file an override names (a
    rule set, a tracker) held when it ran."""
    text = json.dumps({k: v for k, v in cfg.items() if k != "log"}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def same_evaluation(path: Path, cfg: dict, checkpoint: str, episodes: int, seeds: list[int], overrides) -> bool:
    """Whether the eval record at `path` is of this very evaluation: the same checkpoint, episodes, seeds,
    overrides and composed config (records made before they recorded the last two are not), its robots walked by
    the same locomotion policy. The code that ran it is not recorded: as a stage's identity is its config
    (`experiments/stages.py`), so is an evaluation's."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, ValueError):  # none, or damaged: evaluate again
        return False
    lowlevel = cfg.get("lowlevel")
    walker = backend_of(lowlevel).policy_fingerprint(lowlevel) if lowlevel and level_of(cfg).walks_robots else None
    made = {
        "checkpoint": checkpoint,
        "episodes": episodes,
        "seeds": list(seeds),
        "overrides": list(overrides),
        "config_sha256": config_digest(cfg),
    }
    return isinstance(record, dict) and all(record.get(k) == v for k, v in made.items()) and (
        record.get("lowlevel_policy") == (walker or None))  # summarize records none where it walks none  # fmt: skip


def _record_episodes(cfg, checkpoint, episodes, seeds, out_dir, name, live, video) -> list[dict]:
    """Every seed's outcomes, with the episode file, the live view and the video watching."""
    recorders = [eval_video_recorder(cfg, eval_video_path(out_dir, name))] if video else []  # checks the renderer
    recorders += _eval_recorders(cfg, out_dir / f"{Path(EPISODES).stem}{_suffix(name)}.mcap", live)
    try:
        per_seed = [run_episodes(cfg, checkpoint, episodes, s, recorders) for s in seeds]
    except BaseException:  # failed or cut: an episode file that is whole only when finished is dropped
        for recorder in recorders:
            getattr(recorder, "discard", recorder.close)()
        raise
    for recorder in recorders:
        recorder.close()
    return per_seed


def _suffix(name: str) -> str:
    return f"_{name}" if name else ""


def output_dir(run_dir: Path) -> Path:
    """Where an evaluation of `run_dir` writes: the run dir, or for a policy shipped inside the installed package
    `runs/shipped/<its path in the package>` under the working dir."""
    resolved = Path(run_dir).resolve()
    if resolved.is_relative_to(PACKAGE):
        return Path("runs") / "shipped" / resolved.relative_to(PACKAGE)
    return Path(run_dir)


def evaluate_quietly(cfg: dict, checkpoint: Path, episodes: int, seeds: list[int]) -> dict:
    """`evaluate`'s summary of one checkpoint under `cfg`, writing no file (learning curves, benchmarks)."""
    cfg = {**cfg, "log": {**cfg["log"], "eval_episodes": 0}}
    per_seed = [run_episodes(cfg, checkpoint, episodes, s) for s in seeds]
    return summarize(cfg, str(checkpoint), episodes, seeds, per_seed)


def summarize(cfg: dict, policy: str, episodes: int, seeds: list[int], per_seed: list[dict]) -> dict:
    """The eval record (docs/usage.md) of `policy`'s per-seed outcomes (`first_episodes`)."""
    sr = np.array([r["success_rate"] for r in per_seed])
    result = {
        "checkpoint": policy,
        "task": cfg["task"]["name"],
        "num_agents": cfg["task"]["num_agents"],
        "success_rate": float(sr.mean()),
        "success_rate_std": float(sr.std()),
        "completion_time": float(np.mean([r["completion_time"] for r in per_seed])),
        "completion_time_std": float(np.std([r["completion_time"] for r in per_seed])),
        "completion_time_s": float(np.mean([r["completion_time_s"] for r in per_seed])),
        "exceptions": {k: float(np.mean([r["exceptions"][k] for r in per_seed])) for k in per_seed[0]["exceptions"]},
        "timeout_s": per_seed[0]["timeout_s"],
        "episodes": episodes,
        "seeds": seeds,
        "per_seed": per_seed,
        "machine": machine_record(),  # whether a reproduction can expect these bits (docs/reproducibility.md)
    }
    lowlevel, level = cfg.get("lowlevel"), level_of(cfg)
    walker = backend_of(lowlevel).policy_fingerprint(lowlevel) if lowlevel else None
    if walker and level.walks_robots:  # the locomotion policy that walked the robots of a pushing level
        result["lowlevel_policy"] = walker
    # figures only some levels record, averaged over seeds: the high level's reference path length (how far it had
    # to push), the low level's tracking errors and falls (docs/usage.md)
    for key in ("path_length_m", *level.tracking, "fall_rate"):
        if key in per_seed[0]:
            result[key] = float(np.mean([r[key] for r in per_seed]))
    if "events" in per_seed[0]:  # whatever ended the episodes: falls, robot contacts, object tilts (mean over seeds)
        events = per_seed[0]["events"]
        result["events"] = {
            name: {key: float(np.mean([r["events"][name][key] for r in per_seed])) for key in events[name]}
            for name in events
        }
    result["rules"] = cfg["level"].get("rules", "strict")
    return result


def _eval_recorders(cfg: dict, episodes_path: Path, live: bool) -> list:
    """The episode file's recorder (unless `log.eval_episodes` is 0) and the live view when asked for."""
    layout, terms = scene_layout(cfg), list(RewardManager(cfg["reward"]["terms"]).terms)
    exceptions = exception_names(cfg)
    recorders: list = []
    if int(cfg["log"]["eval_episodes"]) > 0:
        recorders.append(EpisodeRecorder(episodes_path, layout, terms, exceptions, whole=True))
    if live:
        view = LiveView(layout, terms, exceptions, int(cfg["log"]["live_port"]))
        print(f"live view: open Foxglove on ws://127.0.0.1:{view.port}", file=sys.stderr, flush=True)
        recorders.append(view)
    return recorders
