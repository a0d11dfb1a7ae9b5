"""MP4 videos of env 0, rendered headless by MuJoCo's offscreen renderer (`mujoco.Renderer`) and encoded to H.264
by PyAV, as the episodes run.

`VideoRecorder` takes the hook the MCAP `EpisodeRecorder` takes (`env.recorders`: `watch`, `capture` after
rewards and before resets, `close`). `mapush eval --video` gives it env 0's first episode of each seed, one after
another in one file; training (`log.video_interval`) env 0's next whole episode every N iterations, one file each.
Call `mapush.viz.preflight.require_offscreen_gl()` before MuJoCo is imported: it picks the OpenGL backend.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from mapush.viz.env_scene import EnvView
from mapush.viz.preflight import check_video_config, require_offscreen_gl

EVAL_VIDEO = "eval_video.mp4"
TRAIN_VIDEO = "train_video_{:05d}.mp4"
IDLE, WAITING, RECORDING = 0, 1, 2


class VideoWriter:
    """An H.264 MP4 written frame by frame with PyAV: `name.mp4.part` until `close()` renames it, so a cut run
    leaves no unplayable `.mp4`."""

    def __init__(self, path: Path, width: int, height: int, fps: int, crf: int):
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


class FrameRenderer:
    """MuJoCo's offscreen renderer on any env of a batch: the model at that env's state, with `EnvView`'s overlays."""

    def __init__(self, env, cfg: dict):
        video = cfg["log"]["video"]
        self.width, self.height = int(video["width"]), int(video["height"])
        self.view = EnvView(env, cfg, self.width, self.height)
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


class VideoRecorder:
    """Renders env 0's episodes to MP4 as they run; attach it with `env.recorders.append(recorder)`.

    Args:
        cfg: the run's config (`log.video`: size, quality, frames per file, episodes per file, camera).
        path_for: the file of a recording that starts at the recorder's env step `step` (counted from 0).
        one_file: every episode into one file, up to `log.video.episodes` (evaluation); else one file each.
    """

    def __init__(self, cfg: dict, path_for: Callable[[int], Path], one_file: bool):
        check_video_config(cfg)
        require_offscreen_gl()
        self.cfg, self.path_for, self.one_file = cfg, path_for, one_file
        video = cfg["log"]["video"]
        self.max_frames, self.max_episodes = int(video["max_frames"]), int(video["episodes"])
        self.renderer: FrameRenderer | None = None
        self.writer: VideoWriter | None = None
        self.written: list[Path] = []
        self.episodes = self.steps = self.every_steps = 0
        self.state, self.env_id, self.fps = IDLE, 0, 50

    def watch(self, env_ids: list[int], dt: float, label: str, from_start: bool, every_steps: int = 0) -> None:
        """Follow the first of `env_ids` of an env with step `dt` (s); `EpisodeRecorder.watch`'s signature."""
        self.env_id, self.fps, self.every_steps = int(env_ids[0]), max(round(1.0 / dt), 1), every_steps
        self.steps = 0
        finished = self.one_file and bool(self.written)  # evaluation: its one file is already complete
        self.state = RECORDING if from_start and not finished else IDLE

    def capture(self, env, commands, reward, parts, done) -> None:
        """Called by the env every step, after rewards and before resets: render env 0 while recording it."""
        self.steps += 1
        if self.every_steps and self.steps % self.every_steps == 0 and self.state == IDLE:
            self.state = WAITING  # the next episode to begin is recorded
        ended = bool(done[self.env_id])
        if self.state == RECORDING:
            self._frame(env, ended)
            if ended or self.state != RECORDING:
                self._end_episode()
        elif self.state == WAITING and ended:
            self.state = RECORDING

    def _frame(self, env, ended: bool) -> None:
        if self.renderer is None:
            self.renderer = FrameRenderer(env, self.cfg)
        if self.writer is None:
            video = self.cfg["log"]["video"]
            path = self.path_for(self.steps - 1)
            path.parent.mkdir(parents=True, exist_ok=True)
            self.writer = VideoWriter(path, self.renderer.width, self.renderer.height, self.fps, int(video["crf"]))
        self.writer.write(self.renderer.render(env, self.env_id))
        if self.writer.frames >= self.max_frames and not ended:
            self.state = IDLE  # the file is full: the rest of this episode is not recorded, and the user is told
            print(
                f"mapush: video {self.writer.path.name} stops at {self.max_frames / self.fps:.1f} s, before the "
                f"episode ends (log.video.max_frames={self.max_frames}; raise it to record whole episodes)",
                file=sys.stderr,
            )
        elif self.writer.frames >= self.max_frames:
            self.state = IDLE

    def _end_episode(self) -> None:
        self.episodes += 1
        self.state = IDLE
        full = self.writer is not None and self.writer.frames >= self.max_frames
        if not self.one_file or self.episodes >= self.max_episodes or full:
            self._finish_file()

    def _finish_file(self) -> None:
        if self.writer is not None:
            self.written.append(self.writer.close())
            self.writer = None

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
