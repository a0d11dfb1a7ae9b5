"""Episode logs: whole episodes of chosen envs as MCAP that Foxglove opens as a 3D scene, and the live view.

Topics (one message per env step unless said otherwise):

- `/scene` (`foxglove.SceneUpdate`): arena, object, robots with their heading, subgoal, and for the high level the
  target, obstacles and reference path (see `mapush.logging.foxglove_scene`); for the low level, the Go1's own geoms and
  its commanded and actual velocity (`mapush.logging.go1_scene`);
- `/tf` (`foxglove.FrameTransforms`): world -> object, world -> robot<i>;
- `/commands` (`mapush.RobotCommands`, JSON): per-robot `vx`, `vy`, `yaw_rate` arrays, index = robot;
- `/rewards` (`mapush.RewardTerms`, JSON): `total` and one array per reward term, index = robot;
- `/log` (`foxglove.Log`), once per episode: its outcome (success, which exception, or timeout) and time;
- `/episode` (`mapush.EpisodeEnd`, JSON), once per episode: the same outcome as fields, plus the return.

Episodes are buffered while they run and written when they end, one after another on the file's timeline
(simulated time from the recording's start, with a 1 s gap between episodes), then flushed: a crash loses at
most the episodes in progress. The file is created with the first finished episode, so it is never left empty.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np
import torch
from foxglove.channels import FrameTransformsChannel, LogChannel, SceneUpdateChannel
from foxglove.mcap import MCAPCompression, MCAPWriteOptions
from foxglove.messages import Log, LogLevel

import foxglove
from foxglove import Channel, Context, Schema
from mapush.atomic import temp_path
from mapush.logging.foxglove_scene import timestamp

FULL_BYTES = 64 * 1024
"""Free bytes under which a failed write is taken for a full disk."""

CHUNK_BYTES = 256 * 1024
"""Small chunks: what a kill leaves is recoverable up to the last flush (tests/unit/logging/test_logs.py)."""
EPISODE_GAP_NS = 1_000_000_000
NUMBERS = {"type": "array", "items": {"type": "number"}}


def _json_schema(title: str, properties: dict) -> Schema:
    body = {"type": "object", "title": title, "properties": properties}
    return Schema(name=title, encoding="jsonschema", data=json.dumps(body).encode())


class EpisodeChannels:
    """The episode topics in one Foxglove context (a file, a live server, or both).

    `layout` draws the scene: a pushing level's `SceneLayout` or the low level's `Go1Layout`
    (`mapush.levels.scene_layout(cfg)`); both give `scene(frame, t_ns)`, `transforms(frame, t_ns)` and `num_agents`.
    """

    def __init__(self, context: Context, layout, term_names: list[str]):
        self.layout = layout
        self.scene = SceneUpdateChannel("/scene", context=context)
        self.tf = FrameTransformsChannel("/tf", context=context)
        self.commands = Channel(
            "/commands",
            schema=_json_schema("mapush.RobotCommands", {k: NUMBERS for k in ("vx", "vy", "yaw_rate")}),
            message_encoding="json",
            context=context,
        )
        self.rewards = Channel(
            "/rewards",
            schema=_json_schema("mapush.RewardTerms", {k: NUMBERS for k in ["total", *term_names]}),
            message_encoding="json",
            context=context,
        )
        self.log = LogChannel("/log", context=context)
        self.episode = Channel(
            "/episode",
            schema=_json_schema(
                "mapush.EpisodeEnd",
                {
                    "episode": {"type": "integer"},
                    "label": {"type": "string"},
                    "outcome": {"type": "string", "enum": ["success", "exception", "timeout"]},
                    "exception": {"type": "string"},
                    "time_s": {"type": "number"},
                    "return": NUMBERS,
                },
            ),
            message_encoding="json",
            context=context,
        )
        self.term_names = term_names

    def log_step(self, row: dict[str, np.ndarray], t_ns: int) -> None:
        """Scene, transforms, commands and rewards of one env at one step."""
        self.scene.log(self.layout.scene(row, t_ns), log_time=t_ns)
        self.tf.log(self.layout.transforms(row, t_ns), log_time=t_ns)
        cmd = row["commands"]
        self.commands.log(
            {"vx": cmd[:, 0].tolist(), "vy": cmd[:, 1].tolist(), "yaw_rate": cmd[:, 2].tolist()}, log_time=t_ns
        )
        rewards = {"total": row["reward"].tolist()}
        rewards.update({name: values.tolist() for name, values in zip(self.term_names, row["terms"], strict=True)})
        self.rewards.log(rewards, log_time=t_ns)

    def log_end(self, row: dict[str, np.ndarray], t_ns: int, number: int, label: str, ret: np.ndarray) -> None:
        """The outcome of an episode whose last step is `row`."""
        kind = int(row["exception_kind"])
        if row["success"]:
            outcome, exception, level = "success", "", LogLevel.Info
        elif kind >= 0:
            outcome, exception, level = "exception", row["exception_names"][kind], LogLevel.Warning
        else:
            outcome, exception, level = "timeout", "", LogLevel.Warning
        time_s = float(row["time_s"])
        text = f"episode {number} ({label}): {outcome}{f' ({exception})' if exception else ''} at {time_s:.2f} s"
        self.log.log(
            Log(timestamp=timestamp(t_ns), level=level, message=text, name="mapush.episode", file="", line=0),
            log_time=t_ns,
        )
        self.episode.log(
            {
                "episode": number,
                "label": label,
                "outcome": outcome,
                "exception": exception,
                "time_s": time_s,
                "return": ret.tolist(),
            },
            log_time=t_ns,
        )


def step_rows(env, env_ids: torch.Tensor, commands, reward, parts: dict) -> dict[str, np.ndarray]:
    """Everything a viewer needs of envs `env_ids` at this step, gathered in one indexing per field."""
    rows = {name: value[env_ids].numpy() for name, value in env.scene_frame().items()}
    rows["commands"] = commands[env_ids].numpy()
    rows["reward"] = reward[env_ids].numpy()
    rows["terms"] = torch.stack([parts[name][env_ids] for name in env.rewards.terms], dim=1).numpy()
    rows["success"] = env.success[env_ids].numpy()
    rows["exception_kind"] = env.exception_kind[env_ids].numpy()
    rows["time_s"] = env.episode_time_s[env_ids].numpy()
    return rows


def _row(rows: dict[str, np.ndarray], j: int, exception_names: tuple[str, ...]) -> dict:
    row = {name: value[j] for name, value in rows.items()}
    row["exception_names"] = exception_names
    return row


IDLE, WAITING, RECORDING = 0, 1, 2


class EpisodeRecorder:
    """Records whole episodes of some envs into an MCAP file; attach it with `env.recorders.append(recorder)`.

    `watch(env_ids, ...)` picks the envs. From the start (`from_start=True`, evaluation: every env is at the
    start of its first episode) it records each watched env's next episode once; with `every_steps=N` (training)
    it records the next episode to begin after every N env steps.
    """

    def __init__(
        self, path: Path, layout, term_names: list[str], exception_names: tuple[str, ...], whole: bool = False
    ):
        self.path = Path(path)
        # whole: written under a temp name and renamed at `close` (an evaluation's file is never seen cut, and a
        # cut one never replaces the last good one); else at its name, flushed per episode (a killed training's
        # file is recovered in place by `mapush logs recover` and by resume)
        self.partial = temp_path(self.path) if whole else self.path
        self.layout, self.term_names, self.exception_names = layout, term_names, exception_names
        self.context: Context | None = None
        self.writer = None
        self.channels: EpisodeChannels | None = None
        self.clock_ns = time.time_ns()
        self.written = 0
        self.dt_ns = 0
        self.env_ids = torch.zeros(0, dtype=torch.long)
        self.state = torch.zeros(0, dtype=torch.long)

    def watch(self, env_ids: list[int], dt: float, label: str, from_start: bool, every_steps: int = 0) -> None:
        """Start watching `env_ids` of an env with step `dt` (s); `label` names them in the episode logs."""
        self.env_ids = torch.as_tensor(env_ids, dtype=torch.long)
        self.state = torch.full((len(env_ids),), RECORDING if from_start else IDLE)
        self.start = np.zeros(len(env_ids), dtype=np.int64)
        self.frames: list[dict[str, np.ndarray]] = []
        self.dt_ns, self.label, self.every_steps, self.steps = round(dt * 1e9), label, every_steps, 0

    def capture(self, env, commands: torch.Tensor, reward: torch.Tensor, parts: dict, done: torch.Tensor) -> None:
        """Called by the env every step, after rewards and before resets."""
        self.steps += 1
        if self.every_steps and self.steps % self.every_steps == 0:
            self.state[self.state == IDLE] = WAITING
        recording = self.state == RECORDING
        ended = done[self.env_ids]
        if recording.any():
            self.frames.append(step_rows(env, self.env_ids, commands, reward, parts))
            for j in (recording & ended).nonzero().flatten().tolist():
                self._write_episode(j)
                self.state[j] = IDLE
        waiting = (self.state == WAITING) & ended
        self.start[waiting.numpy()] = len(self.frames)
        self.state[waiting] = RECORDING
        if not (self.state == RECORDING).any():
            self.frames.clear()

    def _write_episode(self, j: int) -> None:
        try:
            self._log_episode(j)
        except RuntimeError as err:  # the MCAP writer's I/O errors come without their cause
            self._failed(err)

    def _failed(self, err: RuntimeError) -> None:
        """Drop the writer that failed (a whole file's temp file with it) and raise the OSError behind it."""
        writer, self.writer = self.writer, None
        with contextlib.suppress(RuntimeError):  # closed here, not by its finalizer, which would print the error
            writer.close()
        if self.partial != self.path:
            self.partial.unlink(missing_ok=True)
        full = shutil.disk_usage(self.partial.parent).free < FULL_BYTES
        code = errno.ENOSPC if full else errno.EIO
        raise OSError(code, os.strerror(code), str(self.path)) from err

    def _log_episode(self, j: int) -> None:
        rows = [_row(frame, j, self.exception_names) for frame in self.frames[self.start[j] :]]
        if self.writer is None:
            self._open()
        t0 = self.clock_ns
        for k, row in enumerate(rows):
            self.channels.log_step(row, t0 + (k + 1) * self.dt_ns)
        ret = np.sum([row["reward"] for row in rows], axis=0)
        end_ns = t0 + len(rows) * self.dt_ns
        self.channels.log_end(rows[-1], end_ns, self.written, f"{self.label}, env {int(self.env_ids[j])}", ret)
        self.written += 1
        self.clock_ns = end_ns + EPISODE_GAP_NS
        self.writer.flush()

    def _open(self) -> None:
        self.context = Context()
        self.channels = EpisodeChannels(self.context, self.layout, self.term_names)
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, chunk_size=CHUNK_BYTES, compression_threads=0)
        self.writer = foxglove.open_mcap(
            self.partial, allow_overwrite=True, context=self.context, writer_options=options
        )
        self.writer.write_metadata("mapush", {"num_agents": str(self.layout.num_agents), "pid": str(os.getpid())})

    def close(self) -> None:
        """Finish the file (summary and indexes); episodes still running are dropped."""
        if self.writer is not None:
            try:
                self.writer.close()
            except RuntimeError as err:
                self._failed(err)
            self.writer = None
            if self.partial != self.path:
                with open(self.partial, "rb") as f:
                    os.fsync(f.fileno())
                os.replace(self.partial, self.path)

    def discard(self) -> None:
        """Drop a whole file's recording (an evaluation that failed or was cut): the last good file stays."""
        if self.partial == self.path:
            self.close()  # a file written in place keeps what it has, for `mapush logs recover`
            return
        writer, self.writer = self.writer, None
        if writer is not None:
            with contextlib.suppress(RuntimeError):
                writer.close()
        self.partial.unlink(missing_ok=True)


class LiveView:
    """Streams one env's steps to Foxglove over a websocket on 127.0.0.1, paced to real time."""

    def __init__(self, layout, term_names: list[str], exception_names: tuple[str, ...], port: int):
        self.context = Context()
        self.server = foxglove.start_server(name="mapush", host="127.0.0.1", port=port, context=self.context)
        self.channels = EpisodeChannels(self.context, layout, term_names)
        self.exception_names = exception_names
        self.env_ids = torch.zeros(1, dtype=torch.long)
        self.started = time.perf_counter()
        self.steps, self.episodes, self.label, self.dt = 0, 0, "", 0.02
        self.returns = np.zeros(layout.num_agents)

    @property
    def port(self) -> int:
        return self.server.port

    def watch(self, env_ids: list[int], dt: float, label: str, from_start: bool = True, every_steps: int = 0) -> None:
        """Follow the first of `env_ids` of an env with step `dt` (s); the signature is `EpisodeRecorder.watch`'s."""
        self.env_ids = torch.as_tensor(env_ids[:1], dtype=torch.long)
        self.dt, self.label = dt, label
        self.steps, self.started = 0, time.perf_counter()

    def capture(self, env, commands: torch.Tensor, reward: torch.Tensor, parts: dict, done: torch.Tensor) -> None:
        """Publish the watched env's step now, after sleeping until the simulated time catches up with the clock."""
        row = _row(step_rows(env, self.env_ids, commands, reward, parts), 0, self.exception_names)
        self.steps += 1
        ahead = self.steps * self.dt - (time.perf_counter() - self.started)
        if ahead > 0:
            time.sleep(ahead)
        now = time.time_ns()
        self.channels.log_step(row, now)
        self.returns += row["reward"]
        if bool(done[self.env_ids[0]]):
            self.channels.log_end(row, now, self.episodes, f"{self.label}, env {int(self.env_ids[0])}", self.returns)
            self.episodes += 1
            self.returns[:] = 0.0

    def close(self) -> None:
        self.server.stop()
