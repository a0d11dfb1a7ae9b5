"""Videos and the viewer: `mapush eval --video`, `log.video_interval`, `mapush play`, and their refusals.

MuJoCo picks its OpenGL backend when it is first imported, which in a test session has long happened; so whatever
renders runs in a child process (the real CLI, or a short script), and the tests in this process use stand-ins.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path
from types import SimpleNamespace
from typing import ClassVar

import numpy as np
import pytest
from omegaconf import OmegaConf

from mapush.config import CONF_DIR
from mapush.errors import BadInput
from mapush.viz import preflight, video

DEFAULT = OmegaConf.load(CONF_DIR / "config.yaml").log.video
"""Today's video defaults (`log.video`), which the tests of whole episodes are about."""

av = pytest.importorskip("av")


def decoded(path: Path) -> list[np.ndarray]:
    """Every frame of an MP4, decoded with PyAV (the library that wrote it), as (H, W, 3) uint8."""
    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]


def moved(first: np.ndarray, last: np.ndarray) -> float:
    """Fraction of pixels that changed by more than 40 of 255 in some channel: what moved, not codec noise."""
    return float((np.abs(first.astype(int) - last.astype(int)).max(-1) > 40).mean())


# ------------------------------------------------------------------------------------------ the recorder, stand-ins
class FakeRenderer:
    width, height = 32, 16

    def __init__(self, env, cfg):
        pass

    def render(self, env, env_id=0):
        return np.zeros((16, 32, 3), np.uint8)

    def close(self):
        pass


class FakeWriter:
    files: ClassVar[dict[str, int]] = {}
    rates: ClassVar[dict[str, float]] = {}

    def __init__(self, path, width, height, fps, crf):
        self.path, self.frames = Path(path), 0
        FakeWriter.rates[self.path.name] = fps

    def write(self, image):
        self.frames += 1

    def close(self):
        FakeWriter.files[self.path.name] = self.frames
        return self.path


class FakeEnv:
    dt = frame_dt = 0.02

    def __init__(self):
        self.recorders = []


@pytest.fixture
def fake_video(monkeypatch):
    """The recorder with a stand-in renderer and writer: `FakeWriter.files` maps each finished file to its frames."""
    monkeypatch.setattr(video, "FrameRenderer", FakeRenderer)
    monkeypatch.setattr(video, "VideoWriter", FakeWriter)
    monkeypatch.setattr(video, "require_offscreen_gl", lambda: "egl")
    FakeWriter.files, FakeWriter.rates = {}, {}
    return FakeWriter.files


def run_episode(recorder, env, length: int) -> None:
    """`length` captures of which the last ends env 0's episode."""
    for k in range(length):
        recorder.capture(env, None, None, None, np.array([k == length - 1, False]))


def test_eval_video_holds_env_0s_first_episode_of_each_seed_up_to_the_episode_count(cfg_for, fake_video, tmp_path):
    cfg = cfg_for("debug=smoke", "log.video.episodes=2", "log.video.fps=50")  # a frame every 0.02 s step
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video.mp4")
    for length in (3, 4, 5):  # three seeds; the third is past log.video.episodes
        recorder.watch([0, 1], 0.02, "seed", from_start=True)
        run_episode(recorder, FakeEnv(), length)
        run_episode(recorder, FakeEnv(), 2)  # env 0's second episode runs on while the others finish: not recorded
    recorder.close()
    assert fake_video == {"eval_video.mp4": 3 + 4}


def test_eval_video_stops_at_max_seconds(cfg_for, fake_video, tmp_path):
    cfg = cfg_for("debug=smoke", "log.video.episodes=3", "log.video.fps=50", "log.video.max_seconds=0.1")
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video.mp4")
    for length in (3, 4, 4):
        recorder.watch([0], 0.02, "seed", from_start=True)
        run_episode(recorder, FakeEnv(), length)
    recorder.close()
    assert fake_video == {"eval_video.mp4": 5}


def test_a_video_cut_before_its_episode_ends_says_where(cfg_for, fake_video, tmp_path, capsys):
    cfg = cfg_for("debug=smoke", "log.video.fps=50", "log.video.max_seconds=0.1")
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video.mp4")
    recorder.watch([0], 0.02, "seed", from_start=True)
    run_episode(recorder, FakeEnv(), 5)  # ends on its 5th frame: whole, nothing to say
    assert capsys.readouterr().err == ""
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video_long.mp4")
    recorder.watch([0], 0.02, "seed", from_start=True)
    run_episode(recorder, FakeEnv(), 9)
    recorder.close()
    assert "stops at 0.1 s of sim time, before the episode ends (log.video.max_seconds=0.1;" in capsys.readouterr().err


@pytest.mark.parametrize(("steps", "fps", "frames"), [(8000, 10, 1600), (2276, 10, 456), (23, 10, 5), (23, 50, 23)])
def test_a_video_covers_the_whole_episode_a_frame_every_interval(cfg_for, fake_video, tmp_path, steps, fps, frames):
    """A high-level episode's longest (160 s: 8000 steps of 0.02 s) and a successful cuboid one (45.5 s) whole at the
    defaults' playback rate (`log.video.fps` x `log.video.speedup` frames per second of the file)."""
    cfg = cfg_for("debug=smoke", f"log.video.fps={fps}")
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video.mp4")
    recorder.watch([0], 0.02, "seed", from_start=True)
    run_episode(recorder, FakeEnv(), steps)
    recorder.close()
    assert fake_video == {"eval_video.mp4": frames}
    assert FakeWriter.rates == {"eval_video.mp4": DEFAULT.speedup * fps}


def test_the_default_cap_is_past_a_high_level_episode_and_a_lower_one_is_kept(cfg_for, fake_video, tmp_path, capsys):
    assert cfg_for("debug=smoke")["log"]["video"]["max_seconds"] >= 160  # `level=high`'s episode_length_s
    cfg = cfg_for("debug=smoke", "log.video.max_seconds=30")
    recorder = video.eval_video_recorder(cfg, tmp_path / "eval_video.mp4")
    recorder.watch([0], 0.02, "seed", from_start=True)
    run_episode(recorder, FakeEnv(), 8000)
    recorder.close()
    assert fake_video == {"eval_video.mp4": 30 * DEFAULT.fps}  # 30 s of sim time at the default frame rate
    assert "stops at 30.0 s of sim time" in capsys.readouterr().err


def test_a_run_saved_with_max_frames_loads_with_todays_video_length(tmp_path):
    """Runs (and the shipped policies) saved `log.video.max_frames: 1500` (30 s): it is dropped on load, and their
    videos follow today's `log.video.max_seconds`."""
    from mapush.config import load_run_config

    shipped = Path(video.__file__).parents[1] / "policies" / "cuboid" / "high" / "config.yaml"
    assert "max_frames: 1500" in shipped.read_text()
    (tmp_path / "config.yaml").write_text(shipped.read_text())
    loaded = load_run_config(tmp_path).log.video
    assert "max_frames" not in loaded and loaded.max_seconds >= 160 and loaded.fps == DEFAULT.fps


def test_training_video_records_the_next_episode_every_interval_named_by_iteration(cfg_for, fake_video, tmp_path):
    # 4 env steps per iteration, a video every iteration, env 0's episodes end at steps 3, 6, 9, 12, 15
    cfg = cfg_for("debug=smoke", "log.video_interval=1", "algo.num_steps_per_env=4", "log.video.fps=50")
    env = FakeEnv()
    recorder = video.attach_training_video(cfg, env, tmp_path, first_iteration=10)
    assert env.recorders == [recorder]
    for _ in range(5):
        run_episode(recorder, env, 3)
    recorder.close()
    # step 4 arms it, the episode of steps 7-9 is recorded (iteration 10 + 6 // 4); step 12 arms it again: 13-15
    assert fake_video == {"train_video_00011.mp4": 3, "train_video_00013.mp4": 3}


def test_no_training_video_by_default(cfg_for):
    env = FakeEnv()
    assert video.attach_training_video(cfg_for("debug=smoke"), env, Path("unused"), 0) is None
    assert env.recorders == []


@pytest.mark.parametrize("name", ["", "clip", "task.num_agents-3"])
def test_the_eval_video_is_named_like_its_eval_json(name):
    eval_json = Path("run") / (f"eval_{name}.json" if name else "eval.json")
    expected = Path("run") / (f"eval_video_{name}.mp4" if name else "eval_video.mp4")
    assert video.eval_video_of(eval_json) == expected
    assert video.eval_video_path(Path("run"), name) == expected


# ------------------------------------------------------------------------------------------ preflight checks
@pytest.mark.parametrize(
    "override",
    [
        "log.video.width=641",
        "log.video.height=0",
        "log.video_interval=-1",
        "log.video.fps=0",
        "log.video.speedup=-1",
        "log.video.max_seconds=0",
    ],
)
def test_a_bad_video_setting_is_one_line_naming_it(cfg_for, override):
    with pytest.raises(BadInput, match=override.split("=")[0]) as err:
        preflight.check_video_config(cfg_for(override))
    assert "\n" not in str(err.value) and "valid: a" in str(err.value)


def test_no_renderer_names_what_to_install(monkeypatch):
    preflight.require_offscreen_gl.cache_clear()
    monkeypatch.setattr(preflight, "_renders_here", lambda: "FatalError: no OpenGL context")
    try:
        with pytest.raises(BadInput, match="apt-get install libegl1") as err:
            preflight.require_offscreen_gl()
        assert "\n" not in str(err.value)
    finally:
        preflight.require_offscreen_gl.cache_clear()


def test_missing_python_packages_name_the_extra(monkeypatch):
    preflight.require_offscreen_gl.cache_clear()
    monkeypatch.setattr(preflight, "_missing_modules", lambda modules: ["av"])
    try:
        with pytest.raises(BadInput, match=r"pip install -e '\.\[render\]'"):
            preflight.require_offscreen_gl()
    finally:
        preflight.require_offscreen_gl.cache_clear()


def test_the_viewer_needs_a_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    with pytest.raises(BadInput, match="no display"):
        preflight.require_display()


def test_eval_video_without_a_renderer_fails_before_any_result(cli, run_copy, monkeypatch, snapshot):
    """glfw needs a display: with none, `--video` is refused in one line, exit 2, and the run dir is untouched."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("MUJOCO_GL", "glfw")
    before = snapshot(run_copy)
    proc = cli("eval", run_copy, "--video")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("mapush: error: no OpenGL backend renders here") and proc.stderr.count("\n") == 1
    assert snapshot(run_copy) == before


def test_play_without_a_display_is_refused_in_one_line(cli, tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    proc = cli("play", tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith("mapush: error: no display") and proc.stderr.count("\n") == 1


# ------------------------------------------------------------------------------------------ real renders, headless
RENDER_SCRIPT = textwrap.dedent(
    """
    import sys
    from mapush.viz.preflight import require_offscreen_gl
    require_offscreen_gl()  # picks MUJOCO_GL before MuJoCo is imported
    import torch
    from mapush.config import compose_config, to_plain
    from mapush.envs.mid import MidPushEnv
    from mapush.viz.video import eval_video_recorder
    cfg = to_plain(compose_config(["debug=smoke", "task=cylinder", "log.video.fps=50", "log.video.max_seconds=0.4"]))
    env = MidPushEnv(cfg, num_envs=2)
    recorder = eval_video_recorder(cfg, sys.argv[1])
    recorder.watch([0, 1], env.frame_dt, "test", from_start=True)
    env.recorders.append(recorder)
    generator = torch.Generator().manual_seed(0)
    for _ in range(30):
        env.step(torch.rand(2, env.num_agents, 3, generator=generator) * 2 - 1)
    recorder.close()
    """
)


def run_child(script: str, *args: str) -> subprocess.CompletedProcess:
    """`script` in a fresh Python (so it picks its own OpenGL backend) on one thread, with `args` as its argv."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-c", script, *args], env=env, capture_output=True, text=True, timeout=240)


@pytest.mark.slow
def test_a_recorded_episode_of_three_robots_renders_headless_to_the_asked_frames(tmp_path):
    out = tmp_path / "three_robots.mp4"
    proc = run_child(RENDER_SCRIPT, str(out))
    assert proc.returncode == 0, proc.stderr
    frames = decoded(out)
    assert len(frames) == 20
    assert frames[0].shape == (360, 640, 3)
    assert moved(frames[0], frames[-1]) > 0


@pytest.fixture(scope="module")
def cylinder_run(run_cli, tmp_path_factory) -> Path:
    """A smoke run of 3 robots (the cylinder) that renders training videos: 0.2 s episodes, a video every iteration."""
    root = tmp_path_factory.mktemp("video_runs")
    overrides = ["task=cylinder", "log.video_interval=1", "level.episode_length_s=0.2", "train.iterations=4"]
    proc = run_cli(["train", "debug=smoke", f"train.run_root={root}", *overrides], cwd=root)
    assert proc.returncode == 0, proc.stderr
    return Path(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_training_with_a_video_interval_leaves_videos_in_the_run_dir(cylinder_run):
    videos = sorted(cylinder_run.glob("train_video_*.mp4"))
    assert videos, sorted(p.name for p in cylinder_run.iterdir())
    assert all(len(decoded(path)) >= 1 for path in videos)
    assert not list(cylinder_run.glob("*.part"))


@pytest.mark.slow
def test_eval_video_of_a_trained_run_writes_the_asked_frames_next_to_eval_json(cylinder_run, run_cli, tmp_path):
    # 9 frames are 0.18 s: from the default 9 m the robots move about a pixel, so the camera comes closer
    args = ["--video", "log.video.fps=50", "log.video.max_seconds=0.18", "log.video.camera.distance=3.0"]
    args += ["--name", "clip"]
    proc = run_cli(["eval", cylinder_run, *args], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    video_path, eval_json = proc.stdout.strip().splitlines()[-2:]
    assert (video_path, eval_json) == (str(cylinder_run / "eval_video_clip.mp4"), str(cylinder_run / "eval_clip.json"))
    frames = decoded(Path(video_path))
    assert len(frames) == 9
    assert moved(frames[0], frames[-1]) > 0


WHOLE_EPISODE_SCRIPT = textwrap.dedent(
    """
    import sys
    from mapush.viz.preflight import require_offscreen_gl
    require_offscreen_gl()
    import torch
    from mapush.config import compose_config, to_plain
    from mapush.envs.mid import MidPushEnv
    from mapush.viz.video import eval_video_recorder
    small = ["log.video.width=64", "log.video.height=32"]
    cfg = to_plain(compose_config(["debug=smoke", "level.episode_length_s=0.9", *small]))
    env = MidPushEnv(cfg, num_envs=1)
    recorder = eval_video_recorder(cfg, sys.argv[1])
    recorder.watch([0], env.frame_dt, "test", from_start=True)
    env.recorders.append(recorder)
    steps = 0
    while recorder.episodes == 0:
        env.step(torch.zeros(1, env.num_agents, 3))
        steps += 1
    recorder.close()
    print(steps, env.frame_dt)
    """
)


@pytest.mark.slow
def test_a_recorded_episode_is_whole_at_the_default_frame_rate(tmp_path):
    """At the defaults a video holds its whole episode: a frame every 0.1 s of sim time from the first step, and the
    MP4 (read back by PyAV) lasts the episode's sim time over `log.video.speedup`."""
    out = tmp_path / "whole.mp4"
    proc = run_child(WHOLE_EPISODE_SCRIPT, str(out))
    assert proc.returncode == 0, proc.stderr
    steps, dt = proc.stdout.split()
    steps, every = int(steps), round(1 / DEFAULT.fps / float(dt))
    assert every < steps <= round(0.9 / float(dt))  # the episode ends at its timeout, or before on a fall
    with av.open(str(out)) as container:
        stream = container.streams.video[0]
        frames = len([frame for frame in container.decode(stream)])
        duration = float(stream.duration * stream.time_base)
        assert float(stream.average_rate) == pytest.approx(DEFAULT.speedup * DEFAULT.fps)
    assert frames == -(-steps // every)  # ceil: the steps 0, k, 2k, ... of the episode
    assert duration == pytest.approx(frames / (DEFAULT.speedup * DEFAULT.fps))


HIGH_FRAME_SCRIPT = textwrap.dedent(
    """
    import sys
    from mapush.viz.preflight import require_offscreen_gl
    require_offscreen_gl()
    import numpy as np
    from mapush.config import compose_config, to_plain
    from mapush.envs.high import HighPushEnv
    from mapush.rl.frozen import load_mid_policy
    from mapush.viz.video import FrameRenderer
    cfg = to_plain(compose_config(["debug=smoke", "level=high", "mid=" + sys.argv[1]]))
    env = HighPushEnv(cfg, load_mid_policy(sys.argv[1], cfg["task"]), num_envs=1)
    renderer = FrameRenderer(env, cfg)
    np.save(sys.argv[2], renderer.render(env, 0))
    renderer.close()
    """
)


@pytest.mark.slow
def test_a_high_level_frame_shows_the_object_it_tracks(smoke_run, tmp_path):
    # the high level's scene parks unused obstacle blocks 1 km away; MuJoCo's clip planes scale with the extent that
    # makes, and a near plane beyond the camera's distance once left every high-level frame without its object
    out = tmp_path / "frame.npy"
    proc = run_child(HIGH_FRAME_SCRIPT, str(smoke_run), str(out))
    assert proc.returncode == 0, proc.stderr
    frame = np.load(out).astype(int)
    r, g, b = frame[..., 0], frame[..., 1], frame[..., 2]
    orange = (r > g) & (g > b) & (r - b > 80)  # the object's colour (0.9, 0.55, 0.2) under any shading
    assert orange.mean() > 0.005, f"{orange.mean():.4f} of the frame shows the object"


def test_a_high_level_video_frames_the_object_and_the_target():
    """The tracking camera of a level with a final target looks at the middle of object and target, from far enough
    for both (the object alone, 9 m away, left a 10+ m target out of the picture)."""
    import mujoco

    from mapush.viz.env_scene import FRAMING, EnvView

    view = SimpleNamespace(camera_cfg={"track": True, "distance": 9.0}, success_distance=1.0)
    camera = mujoco.MjvCamera()
    row = {"object_xy": np.array([-5.0, 0.0]), "target_xy": np.array([6.0, 2.0])}
    EnvView.frame(view, camera, row)
    assert camera.type == mujoco.mjtCamera.mjCAMERA_FREE
    assert camera.lookat[:2].tolist() == [0.5, 1.0]
    assert camera.distance == pytest.approx(FRAMING * (np.hypot(11.0, 2.0) + 2.0))
    mid_level = mujoco.MjvCamera()  # no target: the camera stays as set_camera placed it
    EnvView.frame(view, mid_level, {"object_xy": np.zeros(2), "subgoal_xy": np.ones(2)})
    assert mid_level.type == mujoco.MjvCamera().type and mid_level.distance == mujoco.MjvCamera().distance
