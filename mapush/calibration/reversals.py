"""Falls under reversing commands: how often a robot topples when its full-scale command keeps changing sign.

Robots walk free (the object parked away), each at the mid level's largest command on every axis (vx, vy, yaw rate at
`level.action_scale`, random signs). At every policy step each axis's sign reverses with probability rate x dt, so
reversals come at `rate` per second per axis on average, for `seconds`. A robot that tilts beyond the pushing
levels' `robot_tilt` threshold has fallen. Rate 0 is a steady walk; a rate near the policy's own (50 per second)
averages to standing still. It asks whether a legged robot stays up under commands as abrupt as a mid level trained on
the tracker may give (`mapush probe commands` measures how abrupt they are).

The tracker does not model these falls (docs/fidelity.md, "Known open deviations"): this is the measurement.

`replay_sweep` asks the same of recorded commands: the seconds before each fall of a hierarchy on Go1s
(`mapush probe falls --replay`), replayed on free robots. If they topple free robots too, the commands alone are
enough; if not, the fall needed what surrounded the robot.
"""

from __future__ import annotations

import numpy as np

from mapush.calibration.capacity import DRAG_FRICTION, FALL_TILT, SETTLE_S
from mapush.calibration.lags import free_layout, run_steps
from mapush.config import compose_config, group_file, to_plain

RATES_HZ = (0.0, 0.25, 0.5, 1.0, 2.0, 5.0, 15.0)
"""Reversals per second per axis: from a steady walk to faster than a Go1's gait (about 3 Hz)."""
SCALE = [float(v) for v in group_file("level", "mid").action_scale]
"""m/s, m/s, rad/s; the full-scale command on each axis (the mid level's `action_scale`)."""


def reversal_sweep(overrides: list[str], envs: int, seconds: float, seed: int, rates=RATES_HZ) -> dict:
    """The robot of `overrides` under commands reversing at each of `rates` (per second per axis), `envs` robots a
    rate, for `seconds`: `rate_hz` (R,), `fell` (R,) the share that fell, `reversals` (R,) the mean reversals per
    second per axis that the robots got."""
    cfg = to_plain(compose_config([*overrides, "task=cuboid", "task.num_agents=1"]))
    n = envs * len(rates)
    rng = np.random.default_rng(seed)
    per_second = np.repeat(np.asarray(rates, dtype=float), envs)[:, None]  # (n, 1): reversals per axis
    sign = rng.choice([-1.0, 1.0], size=(n, 3))
    flips = np.zeros(n)

    def reversing(sim) -> np.ndarray:
        nonlocal sign
        reverse = rng.random((n, 3)) < per_second * sim.dt
        sign = np.where(reverse, -sign, sign)
        flips[:] += reverse.sum(1)
        return sign * SCALE

    run = run_steps(cfg, reversing, free_layout(n, DRAG_FRICTION), SETTLE_S, seconds)
    fell = (run["tilt"] > FALL_TILT).any(1)
    steps = run["tilt"].shape[1]

    def per_rate(values: np.ndarray) -> np.ndarray:
        return values.reshape(len(rates), envs).mean(1)

    return {
        "rate_hz": np.asarray(rates, dtype=float),
        "fell": per_rate(fell.astype(float)),
        "reversals": per_rate(flips / 3 / (steps * run["dt"])),
        "envs": envs,
        "seconds": seconds,
    }


def replay_sweep(overrides: list[str], sequences, dt: float, repeats: int) -> dict:
    """Each of `sequences` ((N, T, 3), or N arrays (T, 3)), body-frame commands a policy step `dt` apart, replayed
    on `repeats` free robots of `overrides` from standing: `fell` (N,), the share of its replays in which the robot
    fell; `robot_vel` (N * repeats, T', 3), each replay's body-frame velocity at every step of the simulator's."""
    cfg = to_plain(compose_config([*overrides, "task=cuboid", "task.num_agents=1"]))
    played = np.repeat(np.asarray(sequences, dtype=float), repeats, 0)  # (N * repeats, T, 3)
    step = {"at": 0}

    def replaying(sim) -> np.ndarray:
        t = min(int(step["at"] * sim.dt / dt + 1e-9), played.shape[1] - 1)
        step["at"] += 1
        return played[:, t]

    run = run_steps(cfg, replaying, free_layout(len(played), DRAG_FRICTION), SETTLE_S, played.shape[1] * dt)
    fell = (run["tilt"] > FALL_TILT).any(1)
    return {
        "fell": fell.reshape(len(played) // repeats, repeats).mean(1),
        "robot_vel": run["robot_vel"],
        "dt": run["dt"],
    }


def print_reversals(overrides: list[str], envs: int, seconds: float, seed: int) -> None:
    """`mapush probe reversals`: the sweep, one line per rate."""
    found = reversal_sweep(overrides, envs, seconds, seed)
    robot = " ".join(overrides) or "the default low level"
    print(f"{robot}: {envs} robots a rate, {seconds:g} s, full-scale commands {SCALE} (vx, vy, yaw rate)")
    print(f"{'reversals/s (asked)':>20s} {'reversals/s (got)':>18s} {'fell':>6s}")
    for rate, got, fell in zip(found["rate_hz"], found["reversals"], found["fell"], strict=True):
        print(f"{rate:20.2f} {got:18.2f} {fell:6.2f}")
