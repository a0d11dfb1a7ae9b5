"""`mapush probe`: what a trained level does inside the episodes `mapush eval` scores, beyond eval.json's figures.

Three probes run `mapush eval`'s first-episode rollout (one episode in each of N envs, seed 0) of a checkpoint, with
its run's config and the given overrides, and watch every step of each env's first episode (`watched_rollout`):

- `commands`: a mid level's velocity commands as shares of `level.action_scale` (the policy's clipped actions), per
  axis (vx, vy, yaw rate): mean magnitude, the share of robot-steps at or beyond 0.95 (saturated), the mean change
  per step (`CommandWatch`). Used to compare seeds whose hierarchies transfer to Go1s differently.
- `falls`: a hierarchy on Go1s (`lowlevel=go1`); at the first step where a robot tilts beyond the high level's
  `robot_tilt` limit, its distances (centre to centre) to the object, to its nearest teammate and to the nearest
  obstacle block, whether its command was at the mid level's full scale on every axis, and how it moved over the
  second before its tumble (`lead_signals`; against its command, off it, the object turning), beside how often every
  robot-step's second passes the same levels (`FallWatch`). Tells falls while pushing or crowding from falls at walls
  or blocks, and what comes before them; `lowlevel=tracker` runs the same on the tracker.
- `progress`: a mid level's pushes, as trained and with other overrides: the object's distance to its subgoal at the
  start and at the end, and the robot-steps spent ahead of the object (on the subgoal's side of the line through its
  centre, square to the push) rather than behind it, where a pusher stands (`PushWatch`).

A fourth, `paths`, rolls nothing out: the lengths of the reference paths the high level is evaluated on, per object
(`path_lengths`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

from mapush.config import apply_overrides, compose_config, load_run_config, to_plain
from mapush.eval.rollout import run_episodes
from mapush.levels import checked, make_env
from mapush.planning.geometry import rotate
from mapush.planning.paths import length as path_length
from mapush.rundir import resolve_checkpoint, shipped_run

SATURATED = 0.95
"""A command at or beyond this share of the action scale counts as saturated (`commands`)."""
FULL_SCALE = 0.99
"""A command at or beyond this share of the mid level's action scale on every axis is at full scale (`falls`)."""
GOT_UP = 0.3
"""rad; a fallen robot tilted back under this has got up again (`falls --go-on`)."""
LEAD_S, TUMBLE_S = 1.0, 1.0
"""s; `falls` reports each motion signal's maximum over the LEAD_S before the last TUMBLE_S before a fall (the
tumble itself, robot rolling over, left out)."""
STILL_MPS = 0.1
"""m/s; a planar command under this tells a robot to (nearly) stand (`falls`' `moved_still_mps`)."""
HISTORY_S = 5.0
"""s; the commands `FallWatch` keeps of each fall's robot, up to its fall (`mapush probe falls --replay` replays
them)."""
LEAD_THRESHOLDS = {
    "against_mps": (0.1, 0.2, 0.3),
    "error_mps": (0.3, 0.5, 0.7),
    "moved_still_mps": (0.1, 0.2, 0.3),
    "object_turn_rps": (0.1, 0.2, 0.4),
}
"""The levels at which `falls` compares the falls' lead-up with every robot-step's (share beyond each)."""


class Watch:
    """A recorder that `mapush.eval.rollout.run_episodes` calls every step (`capture`); it needs no `watch` call."""

    def watch(self, *args, **kwargs) -> None:
        pass

    def capture(self, env, commands, reward, parts, done) -> None:
        raise NotImplementedError


def watched_rollout(target: Path, overrides: list[str], episodes: int, make_watch: Callable[[dict], Watch]):
    """`mapush eval`'s first-episode rollout (`episodes` envs, seed 0) of `target` (a run dir: its latest
    checkpoint; or a model_<it>.pt) with its run's config and `overrides`, watched by `make_watch(cfg)`:
    (outcomes, the watcher)."""
    run_dir, checkpoint = resolve_checkpoint(target)
    cfg = to_plain(apply_overrides(load_run_config(run_dir), overrides))
    cfg["log"]["eval_episodes"] = 0  # no episode file: the watcher is the record
    watch = make_watch(cfg)
    return run_episodes(cfg, checkpoint, episodes, 0, recorders=(watch,)), watch


class CommandWatch(Watch):
    """Each env's first-episode commands, as shares of the action scale."""

    def __init__(self, action_scale: list[float]):
        self.scale = torch.tensor(action_scale)
        self.ended = self.last = None
        self.steps = torch.zeros(())
        self.magnitude, self.saturated, self.change = torch.zeros(3), torch.zeros(3), torch.zeros(3)

    def capture(self, env, commands, reward, parts, done) -> None:
        share = commands / self.scale  # (E, A, 3) in [-1, 1]
        if self.ended is None:
            self.ended, self.last = torch.zeros(env.num_envs, dtype=torch.bool), share.clone()
        live = (~self.ended).float()[:, None, None]  # (E, 1, 1): robot-steps of first episodes only
        self.steps += live.sum() * env.num_agents
        self.magnitude += (share.abs() * live).sum((0, 1))
        self.saturated += ((share.abs() >= SATURATED) * live).sum((0, 1))
        self.change += ((share - self.last).abs() * live).sum((0, 1))
        self.last, self.ended = share.clone(), self.ended | done

    def figures(self) -> dict[str, list[float]]:
        totals = {"mean_abs": self.magnitude, "saturated": self.saturated, "mean_change": self.change}
        return {key: (total / self.steps).tolist() for key, total in totals.items()}


def lead_signals(commands: torch.Tensor, state) -> dict[str, torch.Tensor]:
    """(E, A) motion signals of one step: `against_mps`, the speed against the commanded planar direction (0 under
    a command below STILL_MPS); `error_mps`, the planar speed off the command; `moved_still_mps`, the planar speed of
    a robot told to stand (under STILL_MPS; 0 otherwise); `object_turn_rps`, how fast the object turns (rad/s, the
    same for every robot of an env). Commands are body-frame, velocities world-frame."""
    wanted = rotate(commands[..., :2], state.robot_yaw)  # (E, A, 2) world frame
    vel = state.robot_vel[..., :2]
    norm = wanted.norm(dim=-1)
    moving = norm >= STILL_MPS
    against = -(vel * wanted).sum(-1) / norm.clamp(min=1e-9)
    return {
        "against_mps": torch.where(moving, against.clamp(min=0.0), 0.0),
        "error_mps": (vel - wanted).norm(dim=-1),
        "moved_still_mps": torch.where(moving, 0.0, vel.norm(dim=-1)),
        "object_turn_rps": state.object_vel[:, 2:3].abs().expand_as(norm),
    }


class FallWatch(Watch):
    """Each env's first fall, whether that robot got up again before its episode ended, how often any robot's
    command is at full scale, each motion signal's maximum over the LEAD_S that end TUMBLE_S before the fall
    (`lead_signals`), with the share of all robot-steps whose maximum so taken passes each of LEAD_THRESHOLDS for
    comparison, and the fallen robot's last HISTORY_S of commands (`histories`, to replay)."""

    def __init__(self, max_tilt: float):
        self.max_tilt, self.falls, self.ended = max_tilt, [], None
        self.fallen = self.got_up = None  # (E,): the robot of each env's first fall (-1: none); it stood again
        self.robot_steps, self.saturated_steps = 0, 0  # over every robot and step of the first episodes
        self.lead: list[dict[str, torch.Tensor]] = []  # the last LEAD_S of signals, oldest first
        self.history: list[torch.Tensor] = []  # the last HISTORY_S of commands (E, A, 3), oldest first
        self.histories: list[np.ndarray] = []  # each fall's robot's commands (T, 3), when HISTORY_S of them exist
        self.beyond = {key: torch.zeros(len(levels)) for key, levels in LEAD_THRESHOLDS.items()}  # robot-steps

    def capture(self, env, commands, reward, parts, done) -> None:
        s = env.state
        if self.ended is None:
            self.ended = torch.zeros(env.num_envs, dtype=torch.bool)
            self.fallen = torch.full((env.num_envs,), -1)
            self.got_up = torch.zeros(env.num_envs, dtype=torch.bool)
        live = ~self.ended
        self.dt = env.frame_dt  # s between the steps of `histories`
        kept = round(HISTORY_S / env.frame_dt)  # steps of `history`
        self.history = [*self.history, commands.clone()][-kept:]
        tumble = round(TUMBLE_S / env.frame_dt)
        self.lead = [*self.lead, lead_signals(commands, s)][-(max(1, round(LEAD_S / env.frame_dt)) + tumble) :]
        before = self.lead[: max(1, len(self.lead) - tumble)]
        peak = {key: torch.stack([step[key] for step in before]).amax(0) for key in LEAD_THRESHOLDS}  # (E, A)
        for key, levels in LEAD_THRESHOLDS.items():
            self.beyond[key] += (peak[key][live].unsqueeze(-1) > torch.tensor(levels)).sum((0, 1))
        fallen_tilt = s.robot_tilt.gather(1, self.fallen.clamp(min=0).unsqueeze(1)).squeeze(1)
        self.got_up |= live & (self.fallen >= 0) & (fallen_tilt < GOT_UP)
        fell = (s.robot_tilt > self.max_tilt).any(1) & (self.fallen < 0) & live
        saturated = (commands.abs() >= FULL_SCALE * env.mid.action_scale).all(-1)  # (E, A)
        self.robot_steps += int(live.sum()) * env.num_agents
        self.saturated_steps += int(saturated[live].sum())
        self.ended |= done  # only first episodes count, as in the evaluation
        for e in fell.nonzero().flatten().tolist():
            a = int(s.robot_tilt[e].argmax())
            self.fallen[e] = a
            if len(self.history) == kept:
                self.histories.append(torch.stack([step[e, a] for step in self.history]).numpy())
            teammates = s.robot_distance[e, a][torch.arange(env.num_agents) != a]
            blocks = (env.obstacles[e, :, :2] - s.robot_xy[e, a]).norm(dim=1)
            self.falls.append(
                {
                    "time_s": float(env.episode_time_s[e]),
                    "object_m": float((s.robot_xy[e, a] - s.object_xy[e]).norm()),
                    "teammate_m": float(teammates.min()) if len(teammates) else float("nan"),
                    "obstacle_m": float(blocks.min()) if len(blocks) else float("nan"),
                    "saturated_command": bool(saturated[e, a]),
                    **{key: float(peak[key][e, a]) for key in LEAD_THRESHOLDS},
                }
            )


class PushWatch(Watch):
    """Each env's first push: the object's start and end distance to its subgoal, the robot-steps ahead of it."""

    def __init__(self):
        self.start = self.last = self.ended = self.succeeded = None
        self.ahead_steps = self.robot_steps = None

    def capture(self, env, commands, reward, parts, done) -> None:
        s = env.state
        distance = torch.linalg.vector_norm(s.object_xy - env.subgoal_xy, dim=-1)
        if self.start is None:
            self.start, self.last = distance.clone(), distance.clone()
            self.ended = torch.zeros(env.num_envs, dtype=torch.bool)
            self.succeeded = torch.zeros(env.num_envs, dtype=torch.bool)
            self.ahead_steps = torch.zeros(env.num_envs)
            self.robot_steps = torch.zeros(env.num_envs)
        live = ~self.ended
        push = env.subgoal_xy - s.object_xy  # (E, 2)
        ahead = ((s.robot_xy - s.object_xy.unsqueeze(1)) * push.unsqueeze(1)).sum(-1) > 0  # (E, A)
        self.ahead_steps += (ahead.sum(1) * live).float()
        self.robot_steps += live.float() * env.num_agents
        self.last = torch.where(live, distance, self.last)
        self.succeeded |= env.success & live
        self.ended |= done


def probe_commands(target: Path, episodes: int, overrides: list[str]) -> None:
    """Print a mid level's command statistics over `episodes` pushes."""
    out, watch = watched_rollout(
        target, ["sim.nthread=1", *overrides], episodes, lambda cfg: CommandWatch(cfg["level"]["action_scale"])
    )
    print(f"{target}: S.R. {out['success_rate']:.2f} over {episodes} pushes")
    for key, values in watch.figures().items():
        print(f"  {key:12s} (vx, vy, yaw rate): " + ", ".join(f"{v:.3f}" for v in values))


def probe_falls(target: Path, episodes: int, overrides: list[str], go_on: bool = False) -> FallWatch:
    """Print where a hierarchy's Go1s fall over `episodes` episodes: quartiles of the distances at each first fall.
    With `go_on`, a fall does not end the episode (`robot_tilt` left out of `level.terminal_exceptions`), and the
    share of fallen robots that got up again is printed too. Returns the watcher (its `histories` to replay)."""
    if go_on:
        terminal = load_run_config(resolve_checkpoint(target)[0])["level"]["terminal_exceptions"]
        kept = ",".join(kind for kind in terminal if kind != "robot_tilt")
        overrides = [f"level.terminal_exceptions=[{kept}]", *overrides]
    out, watch = watched_rollout(
        target,
        ["lowlevel=go1", *overrides],
        episodes,
        lambda cfg: FallWatch(float(cfg["level"]["exceptions"]["robot_tilt"]["params"]["max_rad"])),
    )
    print(f"success {out['success_rate']:.2f}; episodes ended by: "
          + ", ".join(f"{k} {v:.2f}" for k, v in out["exceptions"].items() if v))  # fmt: skip
    overall = watch.saturated_steps / max(watch.robot_steps, 1)
    if not watch.falls:
        print(f"0 envs with a fall; commands at full scale on all three axes: {overall:.2f} of all robot-steps")
        return watch
    print(f"{len(watch.falls)} envs with a fall; quartiles (25 / 50 / 75 %):")
    for key in ("time_s", "object_m", "teammate_m", "obstacle_m"):
        values = np.array([f[key] for f in watch.falls])
        print(f"  {key:11s} " + " / ".join(f"{q:.2f}" for q in np.nanpercentile(values, [25, 50, 75])))
    saturated = np.mean([f["saturated_command"] for f in watch.falls])
    print(f"  commands at full scale on all three axes: {saturated:.2f} of the falls, {overall:.2f} of all robot-steps")
    print(f"  maxima over {LEAD_S:g} s, {TUMBLE_S:g} s before: share beyond each level at falls / at all robot-steps")
    for key, levels in LEAD_THRESHOLDS.items():
        at_falls = [np.mean([f[key] > level for f in watch.falls]) for level in levels]
        everywhere = (watch.beyond[key] / max(watch.robot_steps, 1)).tolist()
        shares = zip(levels, at_falls, everywhere, strict=True)
        print(f"    {key:16s}" + "  ".join(f"> {v:g}: {a:.2f} / {b:.2f}" for v, a, b in shares))
    if go_on:
        print(f"  got up again (tilt back under {GOT_UP} rad) before the episode ended: "
              f"{int(watch.got_up.sum())} of {len(watch.falls)} fallen robots")  # fmt: skip
    return watch


def probe_progress(target: Path, episodes: int, compare: list[str]) -> None:
    """Print a mid level's push progress as trained and, when `compare` has overrides, with them."""
    for overrides in [[], compare] if compare else [[]]:
        out, watch = watched_rollout(target, ["sim.nthread=1", *overrides], episodes, lambda cfg: PushWatch())
        report_progress(" ".join(overrides) or "as trained", out, watch)


def report_progress(label: str, out: dict, watch: PushWatch) -> None:
    """Print, for successes and failures apart, the mean start and end distance, the share of pushes that ended
    farther from the subgoal than they started and the share of robot-steps ahead of the object."""
    success = watch.succeeded
    print(f"{label}: S.R. {out['success_rate']:.2f}")
    ahead = watch.ahead_steps / watch.robot_steps.clamp(min=1)
    for name, rows in (("successes", success), ("failures", ~success)):
        if rows.any():
            farther = (watch.last[rows] > watch.start[rows]).float().mean()
            print(f"  {name:9s} {int(rows.sum()):3d}: distance to the subgoal {watch.start[rows].mean():.2f} -> "
                  f"{watch.last[rows].mean():.2f} m; ended farther than it started {farther:.2f}; "
                  f"robot-steps ahead of the object {ahead[rows].mean():.2f}")  # fmt: skip


def path_lengths(tasks: list[str], episodes: int, seed: int, overrides: list[str]) -> None:
    """Print the lengths of the paths `mapush eval` plans (one env per trial, `seed`) for each task's object, on
    the maps the shipped mid level of that task is evaluated on, against the straight distance."""
    print(f"{'task':<20} {'mean':>6} {'min':>5} {'max':>5} {'straight':>8} {'path/straight':>14}   (path lengths, m)")
    for task in tasks:
        cfg = compose_config(
            [
                "level=high",
                f"mid={shipped_run(f'{task}/mid')}",  # the shipped mid level: the map needs one
                f"task={task}",
                f"num_envs={episodes}",
                f"seed={seed}",
                "sim.nthread=1",
                *overrides,
            ]
        )
        env = make_env(checked(cfg), evaluation=True)  # as `mapush eval` builds it
        path = env.path  # (E, points, 2), start at the object, end at the target
        length = path_length(path)
        straight = (path[:, -1] - path[:, 0]).norm(dim=-1)
        print(
            f"{task:<20} {length.mean():6.1f} {length.min():5.1f} {length.max():5.1f} {straight.mean():8.1f}"
            f" {(length / straight).mean():14.2f}"
        )
