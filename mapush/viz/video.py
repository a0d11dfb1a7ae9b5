"""MP4 videos of env 0, rendered headless by MuJoCo's offscreen renderer (`mujoco.Renderer`) and encoded to H.264
by PyAV, as the episodes run.

`VideoRecorder` takes the hook the MCAP `EpisodeRecorder` takes (`env.recorders`: `watch`, `capture` after
rewards and before resets, `close`). `mapush eval --video` gives it env 0's first episode of each seed, one after
another in one file; training (`log.video_interval`) env 0's next whole episode every N iterations, one file each.
A frame is drawn every `log.video.fps`-th of a second of sim time (every k env steps) and played `log.video.speedup`
times faster than real time, up to `log.video.max_seconds` of sim time per file (a whole high-level episode, 160 s,
by default). Rendering, not physics or encoding, is what a video costs on a CPU (`mapush bench --video`).
Call `mapush.viz.preflight.require_offscreen_gl()` before MuJoCo is imported: it picks the OpenGL backend.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path

import mujoco
import numpy as np

from mapush.viz.env_scene import EnvView
from mapush.viz.preflight import check_video_config, require_offscreen_gl

EVAL_VIDEO = "eval_video.mp4"
TRAIN_VIDEO = "train_video_{:05d}.mp4"
IDLE, WAITING, RECORDING = 0, 1, 2


class VideoWriter:
    """An H.264 MP4 written frame by frame with PyAV at `fps` frames per second of playback: `name.mp4.part` until
    `close()` renames it, so a cut run leaves no unplayable `.mp4`."""

    def __init__(self, path: Path, width: int, height: int, fps: Fraction | int, crf: int):
        import av

        self.path = Path(path)
        self.partial = self.path.with_name(self.path.name + ".part")
        self.container = av.open(str(self.partial), mode="w", format="mp4")
        self.stream = self.container.add_stream("libx264", rate=fps, options={"crf": str(crf), "preset": "veryfast"})
        self.stream.width, self.stream.height, self.stream.pix_fmt = width, height, "yuv420p"
        self.frames = 0
        self._frame_type = av.VideoFrame

    def write(self, image: np.ndarray) -> None:
        """Append one frame, (height, width, 3) uint8 RGB."""
        for packet in self.stream.encode(self._frame_type.from_ndarray(image, format="rgb24")):
            self.container.mux(packet)
        self.frames += 1

    def close(self) -> Path:
        """Flush the encoder, finish the file and give it its name."""
        for packet in self.stream.encode(None):
            self.container.mux(packet)
        self.container.close()
        os.replace(self.partial, self.path)
        return self.path


PLANE_GRID_M = 1.0
"""m; the grid a plain plane (the floor) is drawn in. MuJoCo draws an untextured plane as quads of its third size
(the arena's 0.1 m: 240 x 240 quads); Mesa's CPU renderer spent half of each frame on them, and 1 m quads draw the
same picture under the headlight."""


class FrameRenderer:
    """MuJoCo's offscreen renderer on any env of a batch: the model at that env's state, with `EnvView`'s overlays."""

    def __init__(self, env, cfg: dict):
        video = cfg["log"]["video"]
        self.width, self.height = int(video["width"]), int(video["height"])
        self.view = EnvView(env, cfg, self.width, self.height)
        model = self.view.model  # the view's own copy: the simulation keeps its floor
        plain_planes = (model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE) & (model.geom_matid < 0)
        model.geom_size[plain_planes, 2] = np.maximum(model.geom_size[plain_planes, 2], PLANE_GRID_M)
        self.renderer = mujoco.Renderer(self.view.model, self.height, self.width)
        self.camera = mujoco.MjvCamera()
        self.view.set_camera(self.camera)

    def render(self, env, env_id: int = 0) -> np.ndarray:
        """The picture of env `env_id` now, (height, width, 3) uint8."""
        row = self.view.load(env, env_id)
        self.view.frame(self.camera, row)  # object, path and target in view where the level has a target
        self.renderer.update_scene(self.view.data, camera=self.camera)
        self.view.draw(self.renderer.scene, row)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()  # frees the GL context now, not in a destructor at exit


def frame_interval(fps: float, dt: float) -> int:
    """Env steps of `dt` (s) between two frames at `fps` frames per second of sim time: one at least."""
    return max(round(1.0 / (float(fps) * dt)), 1)


class VideoRecorder:
    """Renders env 0's episodes to MP4 as they run; attach it with `env.recorders.append(recorder)`.

    Each recorded episode's frames are its steps 0, k, 2k, ... (k = `frame_interval(log.video.fps, dt)`), played at
    `log.video.speedup` / (k dt) frames per second; a file holds `log.video.max_seconds` of sim time at most.
    `seconds` sums the wall time of the renderer's and encoder's setup, of rendering and of encoding.

    Args:
        cfg: the run's config (`log.video`: size, quality, frame rate, length, episodes per file, camera).
        path_for: the file of a recording that starts at the recorder's env step `step` (counted from 0).
        one_file: every episode into one file, up to `log.video.episodes` (evaluation); else one file each.
    """

    def __init__(self, cfg: dict, path_for: Callable[[int], Path], one_file: bool):
        check_video_config(cfg)
        require_offscreen_gl()
        self.cfg, self.path_for, self.one_file = cfg, path_for, one_file
        video = cfg["log"]["video"]
        self.max_seconds, self.max_episodes = float(video["max_seconds"]), int(video["episodes"])
        self.renderer: FrameRenderer | None = None
        self.writer: VideoWriter | None = None
        self.written: list[Path] = []
        self.seconds = {"setup": 0.0, "render": 0.0, "encode": 0.0}
        self.episodes = self.steps = self.every_steps = self.episode_step = 0
        self.state, self.env_id = IDLE, 0
        self.watch([0], 0.02, "", from_start=False)

    def watch(self, env_ids: list[int], dt: float, label: str, from_start: bool, every_steps: int = 0) -> None:
        """Follow the first of `env_ids` of an env with step `dt` (s); `EpisodeRecorder.watch`'s signature."""
        video = self.cfg["log"]["video"]
        self.env_id, self.every_steps = int(env_ids[0]), every_steps
        self.interval = frame_interval(video["fps"], dt)  # env steps per frame
        frame_s = Fraction(self.interval * dt).limit_denominator(100_000)  # sim time per frame
        self.rate = Fraction(video["speedup"]).limit_denominator(1000) / frame_s  # frames per second of playback
        self.max_frames = max(int(self.max_seconds / float(frame_s) + 1e-9), 1)
        self.frame_s = float(frame_s)
        self.steps = 0
        finished = self.one_file and bool(self.written)  # evaluation: its one file is already complete
        self._set(RECORDING if from_start and not finished else IDLE)

    def _set(self, state: int) -> None:
        self.state = state
        self.episode_step = 0  # a recording starts with an episode's first step

    def capture(self, env, commands, reward, parts, done) -> None:
        """Called by the env every step, after rewards and before resets: render env 0 while recording it."""
        self.steps += 1
        if self.every_steps and self.steps % self.every_steps == 0 and self.state == IDLE:
            self._set(WAITING)  # the next episode to begin is recorded
        ended = bool(done[self.env_id])
        if self.state == RECORDING:
            if self.episode_step % self.interval == 0:
                self._frame(env, ended)
            self.episode_step += 1
            if ended or self.state != RECORDING:
                self._end_episode()
        elif self.state == WAITING and ended:
            self._set(RECORDING)

    def _frame(self, env, ended: bool) -> None:
        start = time.perf_counter()
        if self.renderer is None:
            self.renderer = FrameRenderer(env, self.cfg)
        if self.writer is None:
            video = self.cfg["log"]["video"]
            path = self.path_for(self.steps - 1)
            path.parent.mkdir(parents=True, exist_ok=True)
            self.writer = VideoWriter(path, self.renderer.width, self.renderer.height, self.rate, int(video["crf"]))
        rendering = time.perf_counter()
        image = self.renderer.render(env, self.env_id)
        encoding = time.perf_counter()
        self.writer.write(image)
        self._add(setup=rendering - start, render=encoding - rendering, encode=time.perf_counter() - encoding)
        if self.writer.frames >= self.max_frames:
            self.state = IDLE  # the file is full: the rest of this episode is not recorded, and the user is told
            if not ended:
                print(
                    f"mapush: video {self.writer.path.name} stops at {self.max_frames * self.frame_s:.1f} s of sim "
                    f"time, before the episode ends (log.video.max_seconds={self.max_seconds:g}; raise it to record "
                    "whole episodes)",
                    file=sys.stderr,
                )

    def _add(self, **seconds: float) -> None:
        for part, value in seconds.items():
            self.seconds[part] += value

    def _end_episode(self) -> None:
        self.episodes += 1
        self.state = IDLE
        full = self.writer is not None and self.writer.frames >= self.max_frames
        if not self.one_file or self.episodes >= self.max_episodes or full:
            self._finish_file()

    def _finish_file(self) -> None:
        if self.writer is not None:
            start = time.perf_counter()
            self.written.append(self.writer.close())
            self.writer = None
            self._add(encode=time.perf_counter() - start)  # the encoder's flush

    def close(self) -> None:
        """Finish the file being written (an episode still running ends the video there) and free the renderer."""
        self._finish_file()
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


def eval_video_path(run_dir: Path, name: str = "") -> Path:
    """`eval_video.mp4` in the run dir, or `eval_video_<name>.mp4` for a named evaluation."""
    stem = Path(EVAL_VIDEO).stem
    return Path(run_dir) / (f"{stem}_{name}.mp4" if name else EVAL_VIDEO)


def eval_video_of(eval_json: Path) -> Path:
    """The video beside an evaluation's result: `eval.json` -> `eval_video.mp4`, `eval_<name>.json` ->
    `eval_video_<name>.mp4` (the name `eval_video_path` was given)."""
    suffix = Path(eval_json).stem.removeprefix("eval")
    return Path(eval_json).with_name(f"{Path(EVAL_VIDEO).stem}{suffix}.mp4")


def eval_video_recorder(cfg: dict, path: Path) -> VideoRecorder:
    """The recorder of `mapush eval --video`: env 0's first episode of each seed, up to `log.video.episodes`."""
    return VideoRecorder(cfg, lambda _step: Path(path), one_file=True)


def attach_training_video(cfg: dict, env, run_dir: Path, first_iteration: int) -> VideoRecorder | None:
    """With `log.video_interval` = N > 0: render env 0's next whole episode every N iterations into
    `train_video_<iteration>.mp4`; None when it is 0. `first_iteration` numbers the files of a resumed run."""
    interval = int(cfg["log"]["video_interval"])
    if interval <= 0:
        return None
    frames_per_step = round(env.dt / env.frame_dt)  # the high level captures every mid-level step
    steps_per_iteration = int(cfg["algo"]["num_steps_per_env"]) * frames_per_step

    def path_for(step: int) -> Path:
        return Path(run_dir) / TRAIN_VIDEO.format(first_iteration + step // steps_per_iteration)

    recorder = VideoRecorder(cfg, path_for, one_file=False)
    recorder.watch([0], env.frame_dt, "training", from_start=False, every_steps=interval * steps_per_iteration)
    env.recorders.append(recorder)
    return recorder
