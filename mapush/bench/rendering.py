"""`mapush bench --video`: what a headless video costs. N frames of env 0 (3 robots pushing the cylinder under seeded
random commands) rendered by MuJoCo's offscreen renderer and encoded to H.264, as `mapush eval --video` does.

The figures: the wall time of the renderer's and encoder's setup, of rendering and of encoding (the video's cost;
physics is timed apart), the frame rate, the file's size, the machine's cores and load before and after.
Call `mapush.viz.preflight.require_offscreen_gl()` before MuJoCo is imported (the command line does).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import torch

from mapush.config import compose_config, to_plain
from mapush.envs.mid import MidPushEnv
from mapush.viz.preflight import require_offscreen_gl
from mapush.viz.video import FrameRenderer, VideoWriter

SCENE = ["task=cylinder", "num_envs=1", "sim.nthread=1"]
"""The scene timed, before the caller's overrides (e.g. log.video.width=1280)."""


def run_video_bench(overrides: list[str], frames: int, out: Path, command: str) -> dict:
    """Render and encode `frames` frames to `out`; the figures (`command`: the command line, recorded with them)."""
    backend = require_offscreen_gl()
    cfg = to_plain(compose_config([*SCENE, *overrides]))
    env = MidPushEnv(cfg, num_envs=1)
    generator = torch.Generator().manual_seed(0)
    load_before = os.getloadavg()
    start = time.perf_counter()
    renderer = FrameRenderer(env, cfg)
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = VideoWriter(out, renderer.width, renderer.height, round(1 / env.frame_dt), cfg["log"]["video"]["crf"])
    setup_s = time.perf_counter() - start
    physics_s = render_s = encode_s = 0.0
    for _ in range(frames):
        t0 = time.perf_counter()
        env.step(torch.rand(1, env.num_agents, 3, generator=generator) * 2 - 1)
        t1 = time.perf_counter()
        image = renderer.render(env, 0)
        t2 = time.perf_counter()
        writer.write(image)
        t3 = time.perf_counter()
        physics_s, render_s, encode_s = physics_s + t1 - t0, render_s + t2 - t1, encode_s + t3 - t2
    t4 = time.perf_counter()
    writer.close()
    renderer.close()
    encode_s += time.perf_counter() - t4  # the encoder's flush
    video_s = setup_s + render_s + encode_s
    return {
        "frames": frames,
        "width": renderer.width,
        "height": renderer.height,
        "robots": env.num_agents,
        "mujoco_gl": backend,
        "video_s": round(video_s, 2),  # renderer and encoder setup + rendering + encoding: what the video costs
        "setup_s": round(setup_s, 2),
        "render_s": round(render_s, 2),
        "encode_s": round(encode_s, 2),
        "physics_s": round(physics_s, 2),  # the env steps, not part of the video's cost
        "frames_per_s": round(frames / video_s, 1),
        "file_mb": round(out.stat().st_size / 2**20, 2),
        "cores": os.cpu_count(),
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in os.getloadavg()],
        "command": command,
    }
