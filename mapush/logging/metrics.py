"""Training scalars to `metrics.mcap`, through an rsl-rl LogWriter, plus the live progress line.

Each scalar tag becomes the topic `/metrics/<tag>` with JSON messages {"iteration": int, "value": float}
(schema `mapush.Scalar`). The stable tags:

- `Reward/<term>`: each reward term's mean episode sum over the episodes that ended in the iteration;
- `Metrics/success_rate`, `Metrics/exception_rate`, `Metrics/episode_time_s`, `Metrics/recent_success_rate`
  (the last 500 episodes), `Train/mean_episode_length` (steps), `Train/mean_reward`;
- `Loss/<name>` (rsl-rl's PPO losses), `Loss/learning_rate`, `Policy/mean_std` (action std);
- `Perf/env_steps_per_s` (env-steps, all robots of an env together), `Perf/total_fps` (rsl-rl's agent rows/s),
  `Perf/collection_time`, `Perf/learning_time`, `Perf/threads` (the iteration's MuJoCo threads), `Perf/cpu_s`
  (the CPU seconds the process spent on the iteration, all its threads together).

With `log.tensorboard=true` the same scalars, tags and iterations also go to TensorBoard event files in
`<run>/tensorboard/` (TensorBoard's own writer, through torch); a resumed run adds a file there, which TensorBoard
reads as one series.

The run's `config.yaml` and `meta.json` (git commit, command) are attached, and `meta.json`'s fields stored as the
metadata record `run`, as soon as the file opens; the rsl-rl config dicts follow. The file is flushed at the end
of every iteration, so a crash loses at most the iteration in progress (`mapush logs recover` restores the rest).
"""

from __future__ import annotations

import json
import os
import sys
import time

from mcap.writer import CompressionType, Writer
from rsl_rl.utils import LogWriter
from rsl_rl.utils.logger import Logger

from mapush.logging.mcap_files import CPU_TAG, THREADS_TAG
from mapush.untrusted import open_own

PART_WAY_DONE = "part_way_done"
"""The step extras' key of the rows whose episode, begun part-way through on a resume, ends in that step."""
TENSORBOARD_DIR = "tensorboard"
"""The run dir's folder of TensorBoard event files (`log.tensorboard=true`)."""

SCALAR_SCHEMA = {
    "type": "object",
    "title": "mapush.Scalar",
    "properties": {"iteration": {"type": "integer"}, "value": {"type": "number"}},
}


def next_free_path(path: str) -> str:
    """`path` if it is free, else `stem.1.ext`, `stem.2.ext`, ...: a resumed run keeps its earlier files."""
    stem, ext = os.path.splitext(path)
    k = 0
    while os.path.exists(path):
        k += 1
        path = f"{stem}.{k}{ext}"
    return path


class McapLogWriter(LogWriter):
    """rsl-rl log writer that records every scalar to MCAP and prints one progress line per iteration.

    Args:
        log_dir: the run dir (given by rsl-rl's Logger).
        filename: MCAP file name inside the run dir.
        total_iterations: the run's final iteration count, for the time-left estimate.
        rows_per_env: policy rows per env, to turn rsl-rl's row-steps/s into env-steps/s.
        progress: print the progress line to stderr.
        threads: MuJoCo threads of this process's iterations, recorded beside their times (0: none recorded).
        record_cpu: record each iteration's CPU seconds (False: as files written before that record).
        tensorboard: also write every scalar to TensorBoard event files in `<log_dir>/tensorboard/`.
    """

    def __init__(
        self,
        log_dir: str,
        filename: str = "metrics.mcap",
        total_iterations: int = 0,
        rows_per_env: int = 1,
        progress: bool = True,
        threads: int = 0,
        record_cpu: bool = True,
        tensorboard: bool = False,
    ):
        self.path = next_free_path(os.path.join(log_dir, filename))
        self._file = open_own(self.path, "wb")  # never through a symlink out of the run
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="mapush")
        self._schema = self._writer.register_schema("mapush.Scalar", "jsonschema", json.dumps(SCALAR_SCHEMA).encode())
        self._channels: dict[str, int] = {}
        self._latest: dict[str, float] = {}
        self.total_iterations, self.rows_per_env, self.progress = total_iterations, rows_per_env, progress
        self.threads = threads  # MuJoCo threads of this process's iterations (a resumed run may differ)
        self._started = time.time()
        self._cpu_mark = time.process_time() if record_cpu else None
        self._first_iteration: int | None = None
        self._tensorboard = None
        if tensorboard:
            from torch.utils.tensorboard import SummaryWriter

            self._tensorboard = SummaryWriter(log_dir=os.path.join(log_dir, TENSORBOARD_DIR), flush_secs=3600)
        self._attach_run_files(log_dir)

    def _attach_run_files(self, log_dir: str) -> None:
        """The run's config and provenance, written and flushed at once: the file never starts out empty."""
        now = time.time_ns()
        for name, media in (("config.yaml", "application/yaml"), ("meta.json", "application/json")):
            path = os.path.join(log_dir, name)
            if os.path.isfile(path):
                with open(path, "rb") as f:
                    self._writer.add_attachment(now, now, name, media, f.read())
        meta_path = os.path.join(log_dir, "meta.json")
        if os.path.isfile(meta_path):
            with open(meta_path) as f:
                meta = json.load(f)
            as_text = {k: v if isinstance(v, str) else json.dumps(v) for k, v in meta.items()}
            self._writer.add_metadata("run", as_text)
        self._writer.flush()
        self._file.flush()

    def add_scalar(self, tag: str, scalar_value: float, global_step: int) -> None:
        """Record one scalar of an iteration."""
        if tag.endswith("/time"):  # rsl-rl's wall-clock duplicates; the iteration series carry the same values
            return
        channel = self._channels.get(tag)
        if channel is None:
            channel = self._channels[tag] = self._writer.register_channel(f"/metrics/{tag}", "json", self._schema)
        now = time.time_ns()
        value = float(scalar_value)
        self._writer.add_message(
            channel, now, json.dumps({"iteration": int(global_step), "value": value}).encode(), now
        )
        self._latest[tag] = value
        if self._tensorboard is not None:
            self._tensorboard.add_scalar(tag, value, int(global_step))
        if tag == "Perf/total_fps":
            self.add_scalar("Perf/env_steps_per_s", value / self.rows_per_env, global_step)
        if tag == "Perf/collection_time" and self._cpu_mark is not None:  # once an iteration: CPU since the last
            now = time.process_time()
            self.add_scalar(CPU_TAG, now - self._cpu_mark, global_step)
            self._cpu_mark = now
        if tag == "Perf/collection_time" and self.threads:
            self.add_scalar(THREADS_TAG, self.threads, global_step)

    def latest(self, tag: str) -> float | None:
        """The last value recorded for `tag` (this iteration's, if it was logged), or None."""
        return self._latest.get(tag)

    def store_config(self, env_cfg: dict | object, train_cfg: dict) -> None:
        """Attach the composed config (env side) and the rsl-rl runner dict."""
        now = time.time_ns()
        for name, cfg in (("config.json", env_cfg), ("train_cfg.json", train_cfg)):
            self._writer.add_attachment(now, now, name, "application/json", json.dumps(cfg, default=str).encode())

    def end_iteration(self, it: int) -> None:
        """Flush the iteration's records to disk and show the progress line."""
        self._writer.flush()  # ends the open chunk: what is on disk is recoverable
        self._file.flush()
        if self._tensorboard is not None:
            self._tensorboard.flush()
        if self._first_iteration is None:
            self._first_iteration = it
        if self.progress:
            sys.stderr.write(self._progress_line(it) + "\n")
            sys.stderr.flush()

    def _progress_line(self, it: int) -> str:
        """Iteration `it` as the metrics and checkpoints number it (`model_<it>.pt`), then how many of the run's
        iterations are done."""
        done = it + 1 - self._first_iteration
        left = max(self.total_iterations - it - 1, 0)
        eta = (time.time() - self._started) / max(done, 1) * left
        steps = self._latest.get("Perf/env_steps_per_s", 0.0)
        return (
            f"iter {it} ({it + 1}/{self.total_iterations} done) | {steps:,.0f} env-steps/s | "
            f"reward {self._latest.get('Train/mean_reward', float('nan')):.3f} | "
            f"success {100 * self._latest.get('Metrics/recent_success_rate', float('nan')):.1f}% | "
            f"left {int(eta) // 60}m{int(eta) % 60:02d}s"
        )

    def stop(self) -> None:
        """Finish the MCAP file (summary and index)."""
        if not self._file.closed:
            self._writer.finish()
            self._file.close()
        if self._tensorboard is not None:
            self._tensorboard.close()


class IterationLogger(Logger):
    """rsl-rl's Logger, plus an `end_iteration` call to the writer after each iteration's scalars are written, and
    readouts that go on across a resume: the reward and length windows travel in the checkpoint (`readouts`,
    `restore`), and the part-way episodes a resume starts with stay out of them (`PART_WAY_DONE`)."""

    def process_env_step(self, rewards, dones, extras, intrinsic_rewards=None) -> None:
        part_way = extras.get(PART_WAY_DONE)
        if part_way is None or not part_way.any():
            return super().process_env_step(rewards, dones, extras, intrinsic_rewards)
        super().process_env_step(rewards, dones & ~part_way, extras, intrinsic_rewards)
        self.cur_reward_sum[part_way] = 0  # ended, but not whole: dropped rather than counted
        self.cur_episode_length[part_way] = 0

    def readouts(self) -> dict:
        """The reward and episode-length windows and the step and time totals, to keep in a checkpoint."""
        return {
            "rewards": list(self.rewbuffer),
            "lengths": list(self.lenbuffer),
            "total_steps": self.tot_timesteps,
            "total_time": self.tot_time,
        }

    def restore(self, saved: dict) -> None:
        """Continue the windows and totals of a checkpoint (`readouts`)."""
        self.rewbuffer.extend(float(v) for v in saved["rewards"])
        self.lenbuffer.extend(float(v) for v in saved["lengths"])
        self.tot_timesteps, self.tot_time = int(saved["total_steps"]), float(saved["total_time"])

    def log(self, it: int, *args, **kwargs) -> None:
        super().log(it, *args, **kwargs)
        if isinstance(self.writer, McapLogWriter):
            self.writer.end_iteration(it)
