"""Building rsl-rl's OnPolicyRunner for a mapush config, with atomic checkpoints, resume and export."""

from __future__ import annotations

import contextlib
import copy
from pathlib import Path

import numpy as np
import torch
from rsl_rl.runners import OnPolicyRunner

from mapush.atomic import replacing
from mapush.config import sim_threads
from mapush.digests import forget, record
from mapush.errors import BadInput
from mapush.logging.metrics import IterationLogger, McapLogWriter
from mapush.rl.export import export_onnx, export_torchscript
from mapush.rl.policy import actor_shape, read_checkpoint
from mapush.rl.retention import SCORE_KEY, SUCCESS_TAG, Retention
from mapush.rundir import ONNX_FILE, POLICY_FILE
from mapush.untrusted import open_own

READOUTS_KEY = "readouts"
"""Where a checkpoint's `infos` keep the windows its logged means were computed over (`MapushRunner.readouts`)."""


class MapushRunner(OnPolicyRunner):
    """OnPolicyRunner whose checkpoints are written atomically and pruned (`algo.keep_checkpoints`, see
    `mapush.rl.retention`) and whose logger flushes every iteration.

    Torch runs the rollout on `threads[0]` threads and the PPO update on `threads[1]`: between two policy calls
    of the rollout MuJoCo steps the batch on every core, and idle torch workers spinning beside it slowed physics
    by a third on 2 cores (`mapush bench`'s breakdown); the update has the cores to itself.
    """

    def __init__(
        self, env, train_cfg: dict, log_dir: str | None = None, device: str = "cpu", threads: tuple[int, int] = (0, 0)
    ):
        super().__init__(env, train_cfg, log_dir=log_dir, device=device)
        self.logger.__class__ = IterationLogger  # same state, plus a per-iteration flush of the MCAP writer
        rollout_threads, update_threads = (n or torch.get_num_threads() for n in threads)
        torch.set_num_threads(rollout_threads)
        update = self.alg.update

        def update_with_threads() -> dict:
            torch.set_num_threads(update_threads)
            try:
                result = update()
            finally:
                torch.set_num_threads(rollout_threads)
            self.updates_done += 1
            return result

        self.updates_done = 0  # PPO updates finished in this process (`last_finished_iteration`)
        self.first_iteration = 0
        self.alg.update = update_with_threads
        # runs made before `algo.keep_checkpoints` existed keep every checkpoint, as they did
        self.retention = Retention(int(train_cfg.get("keep_checkpoints", 0)))

    def last_finished_iteration(self) -> int | None:
        """The last iteration whose PPO update finished in this process; None before the first."""
        return self.first_iteration + self.updates_done - 1 if self.updates_done else None

    def save(self, path: str, infos: dict | None = None) -> None:
        """Write the checkpoint to a temp file, then rename it into place: a cut never leaves half a file. Only
        then drop the checkpoints that retention does not keep."""
        writer = self.logger.writer
        score = writer.latest(SUCCESS_TAG) if isinstance(writer, McapLogWriter) else None
        saved = self.alg.save()
        saved["iter"] = self.current_learning_iteration
        saved["infos"] = {**(infos or {}), SCORE_KEY: score, READOUTS_KEY: self.readouts()}
        with replacing(Path(path)) as tmp:
            torch.save(saved, tmp)
        self.logger.save_model(path, self.current_learning_iteration)
        self.retention.saved(Path(path), score)

    def readouts(self) -> dict:
        """What the logged means are computed over (the logger's windows, the env's success window): kept in
        every checkpoint, so that a resumed run's readouts go on where the checkpoint left them."""
        outcomes = self._outcomes()
        return {"logger": self.logger.readouts(), "env": outcomes.readouts() if outcomes is not None else None}

    def _outcomes(self):
        """The wrapped env's episode outcomes (`EpisodeOutcomes`), None for an env without them."""
        return getattr(getattr(self.env, "env", None), "outcomes", None)

    def restore_readouts(self, saved: dict) -> None:
        """Continue a checkpoint's readouts (`readouts`); the episodes this process starts part-way through then
        stay out of them (`AgentRowsVecEnv.count_whole_only`)."""
        self.logger.restore(saved["logger"])
        outcomes = self._outcomes()
        if outcomes is not None and saved.get("env"):
            outcomes.restore(saved["env"])
        if hasattr(self.env, "count_whole_only"):
            self.env.count_whole_only = True


def train_cfg_for(cfg: dict, rows_per_env: int, total_iterations: int) -> dict:
    """The rsl-rl runner dict: `algo` as configured, plus mapush's MCAP log writer (which also writes TensorBoard's
    event files with `log.tensorboard=true`; `algo.logger` itself is refused by `check_config`)."""
    train_cfg = copy.deepcopy(cfg["algo"])  # rsl-rl mutates what it is given
    train_cfg["logger"] = {
        "class_name": "mapush.logging.metrics:McapLogWriter",
        "filename": "metrics.mcap",
        "total_iterations": total_iterations,
        "rows_per_env": rows_per_env,
        "progress": bool(cfg["train"]["progress"]),
        "threads": sim_threads(cfg),
        "tensorboard": bool(cfg["log"].get("tensorboard", False)),  # runs saved before the key: none
    }
    return train_cfg


def seed_everything(seed: int) -> None:
    """Seed torch and numpy (the env has its own generator, seeded from the same value)."""
    torch.manual_seed(seed)
    np.random.seed(seed)


def obs_width(runner: OnPolicyRunner) -> int:
    """Width of the actor's observation in the runner's env."""
    return int(runner.env.get_observations()["policy"].shape[-1])


def load_checkpoint(
    runner: OnPolicyRunner, path: Path, obs_dim: int, what: str, weights: bool = False, hint=None
) -> int:
    """Load `path` into `runner` after checking it fits; returns the checkpoint's iteration.

    `weights`: only the networks (actor, and critic where saved), to start a new run from them (`train.init_from`);
    the optimizer and the iteration count start fresh. Raises BadInput for a missing file or a checkpoint made for
    another observation width (agent count), with `hint(width)` (the level's `width_hint`) where given.
    """
    if not Path(path).is_file():
        raise BadInput(f"checkpoint {str(path)!r} does not exist; valid: a model_<iteration>.pt of a run dir")
    data = read_checkpoint(path)  # weights only: anything else could run code when unpickled
    trained_dim, _ = actor_shape(data)
    if trained_dim != obs_dim:
        fits = f" ({hint(trained_dim)})" if hint else ""
        raise BadInput(
            f"checkpoint {str(path)!r} expects a {trained_dim}-d observation but {what} gives "
            f"{obs_dim}-d; valid: the task and agent count it was trained with{fits}"
        )
    # A shipped policy's checkpoint keeps the actor alone (`mapush ship`): load what is there.
    parts = {"actor": True, "iteration": not weights, "rnd": "rnd_state_dict" in data and not weights}
    parts |= {"critic": "critic_state_dict" in data, "optimizer": "optimizer_state_dict" in data and not weights}
    if runner.alg.load(data, parts, True):  # the dict read weights-only above; rsl-rl's runner.load unpickles
        runner.current_learning_iteration = int(data["iter"])
    readouts = (data.get("infos") or {}).get(READOUTS_KEY)
    if not weights and readouts and isinstance(runner, MapushRunner):  # checkpoints before them: windows start empty
        runner.restore_readouts(readouts)
    return int(data["iter"])


def learn(runner: MapushRunner, iterations: int, log_path: Path, spread_episodes: bool = True) -> None:
    """Run `iterations` PPO iterations; rsl-rl's console report goes to `log_path`, the writer is always closed.

    `spread_episodes` starts the envs at random points of their first episode, so that episodes do not all time
    out in the same iteration.
    """
    runner.first_iteration, runner.updates_done = runner.current_learning_iteration, 0
    try:
        with open_own(log_path, "a") as log, contextlib.redirect_stdout(log):  # no symlink out of the run
            runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=spread_episodes)
    finally:
        runner.logger.stop_logging_writer()


def export_policy(runner: OnPolicyRunner, run_dir: Path) -> Path:
    """Export the deterministic actor (with its observation normalizer) to ONNX, then to TorchScript: `policy.pt`
    marks a finished run, so it comes last."""
    policy = runner.alg.get_policy()
    forget(run_dir, [ONNX_FILE, POLICY_FILE])  # a cut export leaves files without digests, never wrong ones
    export_onnx(policy.as_onnx(verbose=False), policy.obs_dim, Path(run_dir) / ONNX_FILE)
    path = export_torchscript(policy.as_jit(), Path(run_dir) / POLICY_FILE)
    record(run_dir, [ONNX_FILE, POLICY_FILE])  # loading them checks them (`mapush.digests`)
    return path
