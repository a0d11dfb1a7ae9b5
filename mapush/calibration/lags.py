"""How fast the robot follows a command: step commands from standing, and the first-order lag that fits them.

The free experiments hold step commands (vx, vy, yaw rate at each size in `steps`) from standing, one robot per env,
the object parked far away. The tracker's lags are fitted to the responses: the first-order step response
v(t) = v_ss (1 - exp(-t / lag)), least squares over a grid of lags. A robot that holds less than `STEADY_MIN` of a
step in steady state does not follow a first-order lag; the calibration reports its lag instead of writing it.
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.lowlevel import backend_of
from mapush.planning.geometry import rotate
from mapush.sim.push import PushSim

LAG_GRID = np.geomspace(0.02, 1.0, 60)
"""Candidate lags, s: the physical bounds of a velocity loop of a 12 kg robot."""
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
    cfg: dict,
    commands,
    layout: dict,
    settle_s: float,
    duration_s: float,
    configure=None,
    during=None,
    after=None,
    substep=None,
) -> dict[str, np.ndarray]:
    """Stand for `settle_s`, then hold `commands` (E, 3), every robot of an env told the same, or (E, A, 3), or
    follow `commands(sim)`, called before every step for that step's (E, 3), for `duration_s`. Returns, at every
    policy step of the hold: `robot_vel` (E, T, 3), robot 0's body-frame velocity; `object_speed` (E, T), the
    object's planar speed; `tilts` (E, T, A), every robot's tilt, and `tilt` (E, T), the most tilted robot's. E is
    the layout's. `configure(sim)` may edit per-env model values first; `during(sim)` runs before every step of the
    hold (e.g. to apply a load), `after(sim)` after it (e.g. to read the low level's state), `substep(sim)` after
    each of its physics steps (e.g. to read contacts)."""
    n, agents = len(layout["object_xy"]), int(cfg["task"]["num_agents"])
    backend = backend_of(cfg["lowlevel"])(cfg["lowlevel"])
    sim = PushSim(cfg["sim"], cfg["task"], backend, n)
    if configure is not None:
        configure(sim)
    sim.reset(np.arange(n), layout)
    zero = torch.zeros(n, agents, 3)
    for _ in range(round(settle_s / sim.dt)):
        sim.step(zero)

    def as_input(values: np.ndarray) -> torch.Tensor:
        values = torch.from_numpy(values).float()
        return values if values.dim() == 3 else values.unsqueeze(1).expand(n, agents, 3)

    held = None if callable(commands) else as_input(commands)
    robot_vel, object_speed, tilt = [], [], []
    for _ in range(round(duration_s / sim.dt)):
        if during is not None:
            during(sim)
        sim.step(as_input(commands(sim)) if held is None else held, substep and (lambda: substep(sim)))
        if after is not None:
            after(sim)
        state = sim.read()
        yaw = state.robot_yaw[:, 0]
        vel = state.robot_vel[:, 0]
        body = torch.cat([rotate(vel[:, :2], yaw, inverse=True), vel[:, 2:3]], -1)
        robot_vel.append(body.numpy())
        object_speed.append(torch.linalg.vector_norm(state.object_vel[:, :2], dim=-1).numpy())
        tilt.append(state.robot_tilt.numpy())
    return {
        "robot_vel": np.stack(robot_vel, 1),
        "object_speed": np.stack(object_speed, 1),
        "tilt": np.stack(tilt, 1).max(-1),
        "tilts": np.stack(tilt, 1),
        "dt": sim.dt,
    }


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


def fit_lag(response: np.ndarray, commanded: np.ndarray, dt: float) -> float:
    """The lag (s) of `LAG_GRID` whose first-order step responses best fit `response` (E, T) to `commanded` (E,)."""
    t = (np.arange(response.shape[1]) + 1) * dt
    model = commanded[:, None, None] * (1.0 - np.exp(-t[None, None, :] / LAG_GRID[None, :, None]))  # (E, G, T)
    error = ((model - response[:, None, :]) ** 2).sum((0, 2))
    return float(LAG_GRID[error.argmin()])


def at_grid_bound(lag: float) -> str | None:
    """What a fitted lag at either end of `LAG_GRID` means (a bound, not a fit), or None inside it."""
    if lag not in (LAG_GRID[0], LAG_GRID[-1]):
        return None
    quick = "quickly" if lag == LAG_GRID[0] else "slowly"
    return f"{lag:g} s is the fit grid's bound: the robot responds at least this {quick}"


def steady_fractions(response: np.ndarray, commands: np.ndarray, tail: int) -> dict[str, float]:
    """Per axis (`AXES`), the mean over the step commands along it of the free response's last `tail` steps as a
    share of the command: about 1 for a robot that holds what it is told, as a first-order lag does."""
    shares = {}
    for axis, name in enumerate(AXES):
        rows = np.flatnonzero(commands[:, axis] != 0)
        shares[name] = float((response[rows, -tail:, axis].mean(1) / commands[rows, axis]).mean())
    return shares
