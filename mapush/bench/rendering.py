"""`mapush bench --video`: what the video of one whole high-level episode costs. The shipped cuboid hierarchy's
first evaluation episode (`TARGET`, seed 0, one env) runs as `mapush eval TARGET --video --episodes 1 --seeds 0`
runs it, with its video at the default `log.video` settings (or the overrides given), into `--out`.

The figures: the episode's sim time and wall time, and of that wall time the video's part (the renderer's and
encoder's setup, rendering, encoding: `VideoRecorder.seconds`) and the rest (physics, policies, planner); the
frames, the interval between them, the MP4's frame rate and duration as PyAV reads them back, the file's size, the
machine's cores and load before and after. Call `mapush.viz.preflight.require_offscreen_gl()` before MuJoCo is
imported (the command line does).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.eval.rollout import run_episodes
from mapush.rundir import resolve_checkpoint
from mapush.viz.preflight import require_offscreen_gl
from mapush.viz.video import eval_video_recorder

TARGET = "shipped:cuboid"
"""The hierarchy timed: the shipped cuboid high level over its mid level (an episode of up to 160 s)."""
SEED = 0


def run_video_bench(overrides: list[str], out: Path, command: str) -> dict:
    """Run `TARGET`'s first episode of seed 0 with its video written to `out`; the figures (`command`: the
    command line, recorded with them)."""
    import av

    backend = require_offscreen_gl()
    run_dir, checkpoint = resolve_checkpoint(Path(TARGET))
    cfg = to_plain(apply_overrides(load_run_config(run_dir), overrides))
    out.parent.mkdir(parents=True, exist_ok=True)
    recorder = eval_video_recorder(cfg, out)
    load_before = os.getloadavg()
    start = time.perf_counter()
    outcome = run_episodes(cfg, checkpoint, 1, SEED, (recorder,))
    recorder.close()
    wall_s = time.perf_counter() - start
    video_s = sum(recorder.seconds.values())
    with av.open(str(out)) as container:
        stream = container.streams.video[0]
        frames = sum(1 for _ in container.decode(stream))
        duration_s = float(stream.duration * stream.time_base) if stream.duration else float("nan")
    video = cfg["log"]["video"]
    return {
        "target": TARGET,
        "seed": SEED,
        "success": bool(outcome["success_rate"]),
        "episode_s": round(outcome["completion_time_s"], 2),  # sim time: to success, or the timeout
        "timeout_s": outcome["timeout_s"],
        "frames": frames,
        "frame_every_steps": recorder.interval,
        "frame_every_s": recorder.frame_s,
        "speedup": video["speedup"],
        "playback_fps": float(recorder.rate),
        "video_duration_s": round(duration_s, 2),  # the MP4's own length, read back with PyAV
        "width": int(video["width"]),
        "height": int(video["height"]),
        "mujoco_gl": backend,
        "wall_s": round(wall_s, 2),  # the whole episode with its video: seconds per episode
        "video_s": round(video_s, 2),  # renderer and encoder setup + rendering + encoding: what the video costs
        "setup_s": round(recorder.seconds["setup"], 2),
        "render_s": round(recorder.seconds["render"], 2),
        "encode_s": round(recorder.seconds["encode"], 2),
        "physics_s": round(wall_s - video_s, 2),  # env steps, policies and planner: the episode without a video
        "render_ms_per_frame": round(1000 * recorder.seconds["render"] / max(frames, 1), 1),
        "file_mb": round(out.stat().st_size / 2**20, 2),
        "cores": os.cpu_count(),
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in os.getloadavg()],
        "command": command,
    }
