"""Time a headless video: N frames of env 0 (3 robots pushing the cylinder under random commands) rendered by
MuJoCo's offscreen renderer and encoded to H.264, as `mapush eval --video` does. A benchmark, not a test.

    .venv/bin/python tools/bench_video.py                       # 1000 frames, 640 x 360 -> runs/video_dev/bench.mp4
    .venv/bin/python tools/bench_video.py --frames 200 --json runs/video_dev/bench.json log.video.width=1280 ...

Prints the wall time of rendering and of encoding (physics is timed apart), the machine's cores and load.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=Path("runs/video_dev/bench.mp4"))
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. log.video.width=1280")
    args = parser.parse_args()

    from mapush.viz.preflight import require_offscreen_gl

    backend = require_offscreen_gl()  # before MuJoCo is imported
    import torch

    from mapush.config import compose_config, to_plain
    from mapush.envs.mid import MidPushEnv
    from mapush.viz.video import FrameRenderer, VideoWriter

    cfg = to_plain(compose_config(["task=cylinder", "num_envs=1", "sim.nthread=1", *args.overrides]))
    env = MidPushEnv(cfg, num_envs=1)
    generator = torch.Generator().manual_seed(0)
    load_before = os.getloadavg()
    start = time.perf_counter()
    renderer = FrameRenderer(env, cfg)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    writer = VideoWriter(args.out, renderer.width, renderer.height, round(1 / env.frame_dt), cfg["log"]["video"]["crf"])
    setup_s = time.perf_counter() - start
    physics_s = render_s = encode_s = 0.0
    for _ in range(args.frames):
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
    result = {
        "frames": args.frames,
        "width": renderer.width,
        "height": renderer.height,
        "robots": env.num_agents,
        "mujoco_gl": backend,
        "video_s": round(video_s, 2),  # renderer and encoder setup + rendering + encoding: what the video costs
        "setup_s": round(setup_s, 2),
        "render_s": round(render_s, 2),
        "encode_s": round(encode_s, 2),
        "physics_s": round(physics_s, 2),  # the env steps, not part of the video's cost
        "frames_per_s": round(args.frames / video_s, 1),
        "file_mb": round(args.out.stat().st_size / 2**20, 2),
        "cores": os.cpu_count(),
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in os.getloadavg()],
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
    }
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
