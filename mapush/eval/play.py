"""`mapush play`: a run's deterministic policy pushing in MuJoCo's native viewer (`mujoco.viewer.launch_passive`),
one env, episode after episode, paced to real time, until the window is closed.

The viewer shows the same picture as the videos (`mapush.viz.env_scene`): the model at env 0's state plus the
subgoal's success disc, the target, the reference path and the Go1's velocity arrows as user geoms. It is synced
at every recorder capture, so the high level shows every mid-level step, not only its decisions.
"""

from __future__ import annotations

import time
from pathlib import Path

import torch

from mapush.config import apply_overrides, load_run_config, to_plain
from mapush.levels import build_for_eval
from mapush.rundir import resolve_checkpoint
from mapush.viz.env_scene import EnvView


class ViewerFollower:
    """A recorder (`env.recorders`) that copies env 0 into the passive viewer at every capture, in real time."""

    def __init__(self, viewer, view: EnvView):
        self.viewer, self.view = viewer, view
        self.dt, self.started, self.frames = 0.02, time.perf_counter(), 0

    def watch(self, env_ids: list[int], dt: float, label: str, from_start: bool = True, every_steps: int = 0) -> None:
        self.dt, self.started, self.frames = dt, time.perf_counter(), 0

    def capture(self, env, commands, reward, parts, done) -> None:
        """Show env 0 now, after sleeping until the simulated time catches up with the clock."""
        self.frames += 1
        ahead = self.frames * self.dt - (time.perf_counter() - self.started)
        if ahead > 0:
            time.sleep(ahead)
        with self.viewer.lock():
            row = self.view.load(env, 0)
            self.viewer.user_scn.ngeom = 0
            self.view.draw(self.viewer.user_scn, row)
        self.viewer.sync()

    def close(self) -> None:
        """Nothing to finish: the viewer closes with its window."""


def play(target: Path, overrides: list[str], seed: int) -> None:
    """Run `target`'s (a run dir or checkpoint) policy in the native viewer until its window is closed.

    Call `mapush.viz.preflight.require_display()` first: without a display the viewer cannot open.
    """
    import mujoco.viewer

    run_dir, checkpoint = resolve_checkpoint(target)
    cfg = {**to_plain(apply_overrides(load_run_config(run_dir), overrides)), "seed": seed, "num_envs": 1}
    env, vec, policy = build_for_eval(cfg, checkpoint)
    view = EnvView(env, cfg)
    view.load(env, 0)
    with mujoco.viewer.launch_passive(view.model, view.data) as viewer:
        view.set_camera(viewer.cam)
        follower = ViewerFollower(viewer, view)
        follower.watch([0], env.frame_dt, f"seed {seed}")
        env.recorders.append(follower)
        obs = vec.get_observations()
        with torch.inference_mode():
            while viewer.is_running():
                obs, _, _, _ = vec.step(policy(obs))
