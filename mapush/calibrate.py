"""`mapush calibrate`: fit the tracker's lag and force limit to the legged Go1's command response.

Experiments, one robot per env, all envs of one scene stepped together:
- *free*: step commands from standing (vx, vy, yaw rate at `steps` sizes), the object parked far away;
- *pushing* (one scene per task): the robot starts just behind the object, facing it, and steps vx.

The legged Go1 (`lowlevel=go1`, its locomotion policy) runs every experiment. The tracker's lags are fitted to the
free responses: the first-order step response v(t) = v_ss (1 - exp(-t / lag)), least squares over a grid of lags.
Its force limit is fitted to the pushes: the tracker pushes the same objects with a grid of force limits (one env
per value) and the smallest value whose steady object speed best matches the Go1's wins (a push that does not
saturate the robot fits every larger limit equally). The fitted values replace `lag`,
`yaw_lag` and `max_force` in `conf/lowlevel/tracker.yaml`, except a lag whose axis the robot does not hold in steady
state (`STEADY_MIN`), which is reported instead and stays as it was, also in the tracker that the force limit is
fitted with (`push_lags`); `calibration.json` and `calibration.png` (both responses) go to the output dir.
"""

from __future__ import annotations

import datetime
import json
import re
from pathlib import Path

import numpy as np
import torch
from omegaconf import OmegaConf

from mapush.atomic import write_text
from mapush.config import CONF_DIR, compose_config, to_plain
from mapush.lowlevel import BACKENDS
from mapush.planning.geometry import rotate
from mapush.sim.push import PushSim

LAG_GRID = np.geomspace(0.02, 1.0, 60)
"""Candidate lags, s: the physical bounds of a velocity loop of a 12 kg robot."""
FORCE_GRID = np.linspace(5.0, 150.0, 30)
"""Candidate force limits, N: up to beyond the Go1's ground-friction limit (1.0 x 12 kg x 9.81 = 118 N)."""
PARKED_XY = (9.0, 9.0)
"""Where the object waits during the free experiments, m (the robots start at the origin)."""
LAG_OF_AXIS = {"vx": "lag", "vy": "lag", "yaw_rate": "yaw_lag"}
"""The command axes, in order, and the tracker key whose lag each one's free response fits."""
AXES = tuple(LAG_OF_AXIS)
STEADY_MIN = 0.8
"""A robot that holds less than this share of a step command over its last 0.5 s does not follow a first-order lag:
the calibration says so (`warnings`) instead of trusting the fitted lag."""


def step_commands(steps: list[float]) -> np.ndarray:
    """The free experiments' commands: each step size on each axis, (3 * len(steps), 3)."""
    rows = []
    for axis in range(3):
        for size in steps:
            row = np.zeros(3)
            row[axis] = size
            rows.append(row)
    return np.array(rows)


def run_steps(
    cfg: dict, commands: np.ndarray, layout: dict, settle_s: float, duration_s: float, configure=None
) -> dict[str, np.ndarray]:
    """Stand for `settle_s`, then hold `commands` (E, 3) for `duration_s`; body-frame robot velocities (E, T, 3)
    and object planar speed (E, T) at every policy step of the hold. `configure(sim)` may edit per-env model
    values first."""
    backend = BACKENDS[cfg["lowlevel"]["name"]](cfg["lowlevel"])
    sim = PushSim(cfg["sim"], cfg["task"], backend, len(commands))
    if configure is not None:
        configure(sim)
    ids = np.arange(len(commands))
    sim.reset(ids, layout)
    zero = torch.zeros(len(commands), 1, 3)
    for _ in range(round(settle_s / sim.dt)):
        sim.step(zero)
    held = torch.from_numpy(commands).float().unsqueeze(1)
    robot_vel, object_speed = [], []
    for _ in range(round(duration_s / sim.dt)):
        sim.step(held)
        state = sim.read()
        yaw = state.robot_yaw[:, 0]
        vel = state.robot_vel[:, 0]
        body = torch.cat([rotate(vel[:, :2], yaw, inverse=True), vel[:, 2:3]], -1)
        robot_vel.append(body.numpy())
        object_speed.append(torch.linalg.vector_norm(state.object_vel[:, :2], dim=-1).numpy())
    return {"robot_vel": np.stack(robot_vel, 1), "object_speed": np.stack(object_speed, 1), "dt": sim.dt}


def free_layout(n: int, friction: float) -> dict[str, torch.Tensor]:
    """n robots at the origin facing +x, the object parked out of the way."""
    return {
        "object_xy": torch.tensor(PARKED_XY).expand(n, 2).clone(),
        "object_yaw": torch.zeros(n),
        "robot_xy": torch.zeros(n, 1, 2),
        "robot_yaw": torch.zeros(n, 1),
        "subgoal_xy": torch.tensor(PARKED_XY).expand(n, 2).clone(),
        "friction": torch.full((n,), friction),
    }


def push_layout(n: int, cfg: dict) -> dict[str, torch.Tensor]:
    """n robots right behind the object (its footprint's far side along -x), facing it along +x."""
    from mapush.sim.shapes import object_hull

    hull = np.asarray(object_hull(cfg["task"]["object"]))
    gap = float(-hull[:, 0].min()) + cfg["lowlevel"]["size"][0] / 2 + 0.05
    friction = float(np.mean(cfg["task"]["object"]["friction"]))
    return {
        "object_xy": torch.zeros(n, 2),
        "object_yaw": torch.zeros(n),
        "robot_xy": torch.tensor([-gap, 0.0]).expand(n, 1, 2).clone(),
        "robot_yaw": torch.zeros(n, 1),
        "subgoal_xy": torch.tensor([5.0, 0.0]).expand(n, 2).clone(),
        "friction": torch.full((n,), friction),
    }


def _force_limits(sim: PushSim) -> None:
    """Env k's tracker gets the force limit FORCE_GRID[k] on its x and y actuators."""
    limits = sim.batch.expand("actuator_forcerange")
    for axis in sim.lowlevel.ctrl_idx[0, :2]:
        limits[:, axis, 0], limits[:, axis, 1] = -FORCE_GRID, FORCE_GRID


def fit_lag(response: np.ndarray, commanded: np.ndarray, dt: float) -> float:
    """The lag (s) of `LAG_GRID` whose first-order step responses best fit `response` (E, T) to `commanded` (E,)."""
    t = (np.arange(response.shape[1]) + 1) * dt
    model = commanded[:, None, None] * (1.0 - np.exp(-t[None, None, :] / LAG_GRID[None, :, None]))  # (E, G, T)
    error = ((model - response[:, None, :]) ** 2).sum((0, 2))
    return float(LAG_GRID[error.argmin()])


def steady_fractions(response: np.ndarray, commands: np.ndarray, tail: int) -> dict[str, float]:
    """Per axis (`AXES`), the mean over the step commands along it of the free response's last `tail` steps as a
    share of the command: about 1 for a robot that holds what it is told, as a first-order lag does."""
    shares = {}
    for axis, name in enumerate(AXES):
        rows = np.flatnonzero(commands[:, axis] != 0)
        shares[name] = float((response[rows, -tail:, axis].mean(1) / commands[rows, axis]).mean())
    return shares


def calibrate(
    reference: list[str],
    tasks: list[str],
    steps: list[float],
    settle_s: float,
    duration_s: float,
    out_dir: Path,
    config_path: Path,
) -> dict:
    """Run the experiments, fit, write `config_path` (tracker.yaml), `calibration.json` and `calibration.png`.

    Args:
        reference: overrides that select the robot to measure, e.g. `["lowlevel=go1", "lowlevel.policy=P"]`.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    go1_overrides = [*reference, "task.num_agents=1"]
    go1_cfg = to_plain(compose_config(go1_overrides))
    robot = go1_cfg["lowlevel"]
    source = f"go1, policy {robot['policy'] or 'shipped'}" if robot["name"] == "go1" else robot["name"]
    commands = step_commands(steps)
    free = run_steps(go1_cfg, commands, free_layout(len(commands), 0.5), settle_s, duration_s)
    n = len(steps)
    linear = np.concatenate([free["robot_vel"][:n, :, 0], free["robot_vel"][n : 2 * n, :, 1]])
    lag = fit_lag(linear, np.concatenate([commands[:n, 0], commands[n : 2 * n, 1]]), free["dt"])
    yaw_lag = fit_lag(free["robot_vel"][2 * n :, :, 2], commands[2 * n :, 2], free["dt"])
    tail = max(1, round(0.5 / free["dt"]))  # steady state: the last 0.5 s
    steady = steady_fractions(free["robot_vel"], commands, tail)
    untrusted = {LAG_OF_AXIS[axis]: share for axis, share in steady.items() if share < STEADY_MIN}
    # the force limit is fitted with the lags the tracker will have: a refused fit keeps the config's own
    kept = OmegaConf.load(config_path)
    lags = {"lag": lag, "yaw_lag": yaw_lag}
    push_lags = {key: float(kept[key]) if key in untrusted else value for key, value in lags.items()}
    push_speed = max(steps)
    pushes = {}
    for task in tasks:
        legged_cfg = to_plain(compose_config([*go1_overrides, f"task={task}"]))
        legged = run_steps(
            legged_cfg, np.array([[push_speed, 0.0, 0.0]]), push_layout(1, legged_cfg), settle_s, duration_s
        )
        tracker_cfg = to_plain(compose_config(["lowlevel=tracker", "task.num_agents=1", f"task={task}"]))
        tracker_cfg["lowlevel"].update(push_lags)
        grid = len(FORCE_GRID)  # one env per candidate force limit
        run = run_steps(
            tracker_cfg,
            np.tile([push_speed, 0.0, 0.0], (grid, 1)),
            push_layout(grid, tracker_cfg),
            0.0,
            duration_s,
            configure=_force_limits,
        )
        pushes[task] = {"legged": legged["object_speed"][0], "tracker": run["object_speed"]}
    error = sum((p["tracker"][:, -tail:].mean(1) - p["legged"][-tail:].mean()) ** 2 for p in pushes.values())  # (G,)
    # every limit above what the push needs fits equally well: take the smallest of the best fits
    max_force = float(FORCE_GRID[error <= error.min() * 1.01 + 1e-6][0]) if pushes else None
    fitted = {**lags, **({"max_force": max_force} if max_force is not None else {})}
    warnings = [
        f"{key}: the robot holds {share:.0%} of its step command after {duration_s:g} s, which no first-order lag "
        f"does; {key} left as it was in {config_path} ({push_lags[key]:.4g} s, which the force fit used)"
        for key, share in untrusted.items()
    ]
    write_tracker_config(config_path, {k: v for k, v in fitted.items() if k not in untrusted}, source)
    summary = {
        "fitted": fitted,
        "steady_fraction": steady,
        "push_lags": push_lags,
        "warnings": warnings,
        "reference": reference,
        "steps": steps,
        "settle_s": settle_s,
        "duration_s": duration_s,
        "dt": free["dt"],
        "free": {"commands": commands.tolist(), "legged": free["robot_vel"].tolist()},
        "push": {
            t: {
                "legged_object_speed": p["legged"].tolist(),
                "tracker_steady_speed": p["tracker"][:, -tail:].mean(1).tolist(),
            }
            for t, p in pushes.items()
        },
        "force_grid": FORCE_GRID.tolist(),
    }
    write_text(out_dir / "calibration.json", json.dumps(summary, indent=1) + "\n")
    plot_calibration(free, commands, fitted, pushes, out_dir / "calibration.png")
    return summary


def write_tracker_config(path: Path, fitted: dict, source: str) -> None:
    """Replace the fitted keys' values in tracker.yaml; every other line, and each key's own comment, stay."""
    text = Path(path).read_text()
    stamp = datetime.date.today().isoformat()
    for key, value in fitted.items():
        pattern = re.compile(rf"^{key}:[ \t]*[^#\n]*?(?:[ \t]*#[ \t]*(.*))?$", re.MULTILINE)
        found = pattern.search(text)
        if not found:
            raise ValueError(f"{path} has no top-level {key!r} to calibrate")
        comment = (found.group(1) or "").split(CALIBRATED)[0].rstrip("; ")
        line = f"{key}: {value:.4g}  # {comment}; {CALIBRATED} {source}, {stamp}".replace("#  ;", "#")
        text = text[: found.start()] + line + text[found.end() :]
    write_text(Path(path), text)


CALIBRATED = "calibrated against"


def plot_calibration(free: dict, commands: np.ndarray, fitted: dict, pushes: dict, out: Path) -> None:
    """The measured robot's responses (solid) against the fitted tracker's (dashed): each free axis, each push."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n_axes = 3 + len(pushes)
    fig, axes = plt.subplots(1, n_axes, figsize=(4 * n_axes, 3.2), squeeze=False)
    t = (np.arange(free["robot_vel"].shape[1]) + 1) * free["dt"]
    per_axis = len(commands) // 3
    for axis in range(3):
        ax = axes[0, axis]
        lag = fitted["yaw_lag"] if axis == 2 else fitted["lag"]
        for k in range(axis * per_axis, (axis + 1) * per_axis):
            line = ax.plot(t, free["robot_vel"][k, :, axis], label=f"measured, step {commands[k, axis]:g}")[0]
            ax.plot(t, commands[k, axis] * (1 - np.exp(-t / lag)), "--", color=line.get_color())
        ax.set_title(f"free {AXES[axis]} (tracker lag {lag:.3f} s)")
        ax.set_xlabel("s")
        ax.legend(fontsize=7)
    for j, (task, p) in enumerate(pushes.items()):
        ax = axes[0, 3 + j]
        ax.plot(t[: len(p["legged"])], p["legged"], label="measured")
        k = int(np.argmin(np.abs(FORCE_GRID - fitted["max_force"])))
        ax.plot(t[: p["tracker"].shape[1]], p["tracker"][k], "--", label=f"tracker, {fitted['max_force']:.0f} N")
        ax.set_title(f"pushing the {task}: object speed")
        ax.set_xlabel("s")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def default_config_path() -> Path:
    """conf/lowlevel/tracker.yaml of this checkout."""
    return CONF_DIR / "lowlevel" / "tracker.yaml"


def physical_bounds() -> dict[str, tuple[float, float]]:
    """What a fitted value may be: the grids' ranges."""
    return {
        "lag": (float(LAG_GRID[0]), float(LAG_GRID[-1])),
        "yaw_lag": (float(LAG_GRID[0]), float(LAG_GRID[-1])),
        "max_force": (float(FORCE_GRID[0]), float(FORCE_GRID[-1])),
    }
