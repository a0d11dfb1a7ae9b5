"""The training driver (`mapush train` and the experiments' stages): make (or reopen) a run dir, train with rsl-rl
PPO, export the policy."""

from __future__ import annotations

import shutil
import signal
import sys
from collections.abc import Callable
from pathlib import Path

from omegaconf import DictConfig

from mapush.atomic import remove_leftovers
from mapush.config import META_FILE, lengthen_run, load_run_config, new_run_dir, save_run_config, to_plain
from mapush.errors import BadInput
from mapush.levels import build, checked, load_into, scene_layout
from mapush.logging.episodes import EpisodeRecorder
from mapush.logging.mcap_files import exit_on_sigterm, repair_in_place
from mapush.logging.metrics import next_free_path
from mapush.records import read_meta
from mapush.rl.runner import export_policy, learn
from mapush.rundir import ONNX_FILE, POLICY_FILE, checkpoint_iteration, checkpoints
from mapush.schema import check_config
from mapush.untrusted import run_lock
from mapush.viz.video import attach_training_video

TRAIN_EPISODES = "train_episodes.mcap"


def train(cfg: DictConfig, overrides: list[str], command: str) -> Path:
    """Train a fresh run; returns its run dir."""
    plain = checked(cfg)  # every mistake fails here, before a run dir exists
    chosen = cfg.train.get("run_dir")
    existed = bool(chosen) and Path(chosen).exists()
    run_dir = new_run_dir(cfg)
    try:
        with run_lock(run_dir, training=True):  # a resume of this run while it trains is refused
            save_run_config(run_dir, cfg, overrides, command)
            print(run_dir, flush=True)
            _run(plain, run_dir)
    except (BadInput, OSError):  # refused (too many envs) or a full disk before any checkpoint: nothing half-made
        if not checkpoints(run_dir):
            _unmake(run_dir, existed, Path(cfg.train.run_root))
        raise
    return run_dir


def _unmake(run_dir: Path, existed: bool, run_root: Path) -> None:
    """Remove what a refused run wrote: an empty dir the user chose is emptied again; a dir made under `run_root`
    goes, with the level and task dirs that held only it."""
    if existed:
        for entry in run_dir.iterdir():
            shutil.rmtree(entry) if entry.is_dir() and not entry.is_symlink() else entry.unlink()
        return
    shutil.rmtree(run_dir, ignore_errors=True)
    root = run_root.resolve()
    for parent in run_dir.resolve().parents:
        if parent == root or not parent.is_relative_to(root) or any(parent.iterdir()):
            break
        parent.rmdir()


def resume(run_dir: Path, iterations: int | None, nthread: int | None = None, command: str = "") -> Path:
    """Continue a cut run from its latest checkpoint up to its configured (or the given) iteration count (a run cut
    after its last iteration but before its export is exported), with
    `nthread` MuJoCo threads if given (a run cut on a machine of other cores; threads are not what it learns, and
    `Perf/threads` records each iteration's), else with those of its config.

    More iterations than the run was made for lengthen it: recorded in the run before it trains on (`lengthen_run`,
    `command` saying by what, once its config is built without refusal), and a finished run's exported policy
    removed, as it no longer holds the run's last iteration.

    A run that another process trains is refused at once (`run_lock`): two trainers would write over each other."""
    load_run_config(run_dir)  # a run dir, with no link out of it, before its lock file is made
    with run_lock(Path(run_dir), training=True):
        return _resume(Path(run_dir), iterations, nthread, command)


def _resume(run_dir: Path, iterations: int | None, nthread: int | None, command: str) -> Path:
    cfg = load_run_config(run_dir)
    longer = iterations is not None and iterations > int(cfg.train.iterations)
    if longer:  # lengthening rewrites meta.json: one cut or altered is refused before the run is touched
        read_meta(Path(run_dir) / META_FILE)
    if iterations is not None:
        cfg.train.iterations = iterations
    if nthread is not None:
        cfg.sim.nthread = nthread
    check_config(cfg)
    found = checkpoints(run_dir)
    if not found:
        raise BadInput(f"run dir {str(run_dir)!r} has no checkpoint to resume from; valid: a run with model_*.pt")
    done = checkpoint_iteration(found[-1]) + 1
    if done >= cfg.train.iterations and not (Path(run_dir) / POLICY_FILE).is_file():  # cut while exporting
        print(run_dir, flush=True)
        return export_finished(run_dir)
    if done >= cfg.train.iterations:
        raise BadInput(f"run {str(run_dir)!r} already has {done} iterations; valid: train.iterations=N with N > {done}")
    print(run_dir, flush=True)

    def lengthen() -> None:
        for name in (POLICY_FILE, ONNX_FILE):
            (Path(run_dir) / name).unlink(missing_ok=True)
        lengthen_run(Path(run_dir), int(iterations), command or f"mapush train --resume (to {iterations} iterations)")

    remove_leftovers(Path(run_dir))  # temp files of the writers the cut killed
    _repair_cut_logs(Path(run_dir))
    _run(to_plain(cfg), Path(run_dir), checkpoint=found[-1], built=lengthen if longer else None)
    return Path(run_dir)


def export_finished(run_dir: Path) -> Path:
    """Export the policy of a run whose last checkpoint holds every iteration (cut while exporting)."""
    cfg = to_plain(load_run_config(run_dir))
    _env, runner = build(cfg, None, int(cfg["train"]["iterations"]))
    load_into(runner, cfg, checkpoints(run_dir)[-1], "the run's config")
    export_policy(runner, run_dir)
    return Path(run_dir)


def export_checkpoint(run_dir: Path, checkpoint: Path, out: Path) -> Path:
    """Export the deterministic actor of one of the run's checkpoints (a cut run's last, or any other) to `out`,
    a new dir: `policy.onnx`, `policy.pt` and their digests, as a finished run's. The run itself is left as it
    is (its own `policy.pt` would mark it finished)."""
    cfg = to_plain(load_run_config(run_dir))
    cfg["num_envs"] = 1  # the actor and its normalizer are the checkpoint's: one env builds them
    _env, runner = build(cfg, None, int(cfg["train"]["iterations"]))
    load_into(runner, cfg, checkpoint, "the run's config")
    out.mkdir(parents=True)
    export_policy(runner, out)
    return out


def _run(cfg: dict, run_dir: Path, checkpoint: Path | None = None, built: Callable[[], None] | None = None) -> None:
    """Train `run_dir` up to `train.iterations`, from scratch or from `checkpoint`, then export the policy.

    `built` runs once the env and learner are built and the checkpoint loaded, when nothing in the config can be
    refused any more (a lengthened run is recorded then, so a refused resume leaves the run as it was)."""
    exit_on_sigterm()
    # SIGINT cuts a run as Ctrl-C does (saving its last iteration) also where the shell started it in the
    # background, which leaves SIGINT ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    total = int(cfg["train"]["iterations"])
    env, runner = build(cfg, run_dir, total)
    done = 0
    if checkpoint is not None:
        done = load_into(runner, cfg, checkpoint, "the run's config") + 1
        runner.current_learning_iteration = done  # rsl-rl would repeat the loaded iteration
    elif cfg["train"]["init_from"]:  # a new run that starts from another run's networks
        load_into(runner, cfg, Path(cfg["train"]["init_from"]), "the config", weights=True)
    if built is not None:
        built()
    interval = int(cfg["log"]["episode_interval"])
    recorder = None
    if interval > 0:
        frames_per_step = round(env.dt / env.frame_dt)  # the high level records every mid-level step
        every_steps = interval * int(cfg["algo"]["num_steps_per_env"]) * frames_per_step
        recorder = attach_episode_recorder(cfg, env, Path(next_free_path(str(run_dir / TRAIN_EPISODES))), every_steps)
    video = attach_training_video(cfg, env, run_dir, done)  # None unless log.video_interval > 0
    try:
        learn(runner, total - done, run_dir / "train.log")
    except KeyboardInterrupt:  # Ctrl-C: keep what was learned since the last checkpoint, say how to go on
        _save_interrupted(runner, run_dir)
        raise SystemExit(130) from None
    finally:
        for hook in (recorder, video):
            if hook is not None:
                hook.close()
    export_policy(runner, run_dir)


def _save_interrupted(runner, run_dir: Path) -> None:
    """Checkpoint the networks after the last iteration that finished (its PPO update done), unless it is saved
    already, and print how to go on. A cut inside an update leaves that update's steps in the saved networks."""
    last = runner.last_finished_iteration()
    path = run_dir / f"model_{last}.pt" if last is not None else None
    if path is not None and not path.exists():
        runner.save(str(path))
        saved = f"{path.name} saved"
    else:
        saved = f"{path.name} was saved already" if path is not None else "no iteration finished"
    if checkpoints(run_dir):
        print(f"mapush: interrupted ({saved}); continue with `mapush train --resume {run_dir}`", file=sys.stderr)
    else:
        print(f"mapush: interrupted ({saved}); nothing to resume, train again", file=sys.stderr)


def attach_episode_recorder(cfg: dict, env, path: Path, every_steps: int) -> EpisodeRecorder:
    """Record env 0's next whole episode after every `every_steps` env steps into `path` (training episodes)."""
    recorder = EpisodeRecorder(path, scene_layout(cfg), list(env.rewards.terms), env.exception_names)
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
