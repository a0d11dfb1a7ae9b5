"""How hard the robot pushes and what load topples it: the two limits the tracker takes from the legged Go1.

- *Push capacity*: each robot starts right behind the cuboid and walks into it at the mid level's largest command
  (`PUSH_SPEED`), the cuboid's floor drag set per env by its mass (`DRAG_GRID`, N). The object's steady speed falls
  as the drag grows; the capacity is the drag at which the median robot no longer moves it (`STALL_SPEED`),
  interpolated between grid points (`fit_capacity`). Below it the speed falls along a line, drag = gain x
  (PUSH_SPEED - speed): the robot's push gain, N per m/s (`fit_push_gain`), which the tracker's velocity actuators
  take as their gain. The same sweep is run on the fitted tracker for the plot.
- *Falls under a held load*: each robot walks at `PUSH_SPEED` while a constant horizontal force (`LOAD_GRID`, N)
  pushes its trunk back, against its starting heading, as the object pushes back on a robot that pushes it, for
  `FALL_WINDOW_S`. A robot that tilts beyond the pushing levels' `robot_tilt` threshold has fallen. A logistic
  P(L) = 1 / (1 + exp(-(L - load_n) / width_n)) is fitted to the falls by maximum likelihood (`fit_fall_curve`).

The two experiments load the Go1 in two ways, and it bears them differently: pushing, it holds every contact load up to
its capacity without a fall (the object's reaction, at the nose), while a load held back on its trunk topples it at a
lower one. So the tracker's fall model keeps the two apart: a held-load channel fitted to the Go1's falls under a held
load, and a contact-load curve whose midpoint is the lowest at which the tracker falls no more often than the Go1 in
every contact test (`consistency.fit_contact_midpoint`): a tracker falls when something drives into it harder than
its Go1 could hold, never for pushing as hard as its Go1 does.

Starts are drawn per env (a lateral offset and a heading error) from `--seed`, so two seeds measure twice.
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.calibration.lags import PARKED_XY, run_steps
from mapush.config import compose_config, group_file, to_plain
from mapush.sim.scene import ROBOT_PREFIX
from mapush.sim.shapes import object_hull

MID = group_file("level", "mid")
PUSH_SPEED = float(MID.action_scale[0])
"""m/s; the mid level's largest command (`level.action_scale`), as a robot pushing hard is told."""
DRAG_GRID = np.arange(2.5, 82.5, 5.0)
"""N; the cuboid's floor drag in the capacity sweep: from a light push to beyond the feet's grip on the floor."""
LOAD_GRID = np.arange(0.0, 126.0, 1.0)
"""N; the held loads of the fall sweep: from none to twice the feet's grip on the floor (0.55 x 12 kg x g = 65 N),
1 N apart so that the fall curve's width is resolved (at 5 N apart the Go1's curve was a step)."""
DRAG_FRICTION = 0.5
"""The cuboid's sliding friction in the capacity sweep; its mass sets the drag (m = drag / (friction g))."""
STALL_SPEED = 0.05
"""m/s; an object slower than this in steady state is not being pushed along."""
FALL_WINDOW_S = 4.0
"""s; how long each load is held, and the window P(L) is the probability of a fall within."""
FALL_TILT = float(MID.exceptions.robot_tilt.params.max_rad)
"""rad; a fall, as the pushing levels' `robot_tilt` exception counts one (conf/level/mid.yaml)."""
LOAD_FILTER_S = 0.2
"""s; the tracker low-passes its contact load over this before the fall model reads it, so that an impact of a few
milliseconds does not count as a held load (a Go1 stride at its 3 Hz gait lasts about 0.33 s)."""
FALL_TIMES = {"window_s": FALL_WINDOW_S, "filter_s": LOAD_FILTER_S}
"""The tracker's `fall` model's time constants, s: the window P(L) is measured over, and the load's low-pass."""
SETTLE_S = 1.0
"""s of standing before each experiment's command."""
PUSH_S, STEADY_S = 6.0, 2.0
"""s; each push lasts PUSH_S and its object speed is averaged over the last STEADY_S."""
OFFSET_M, HEADING_RAD = 0.2, 0.1
"""Each start is drawn within +-OFFSET_M sideways of the object's centre line and +-HEADING_RAD of facing it."""
G = 9.81


def starts(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n lateral offsets (m) and heading errors (rad), drawn from `seed`."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-OFFSET_M, OFFSET_M, n), rng.uniform(-HEADING_RAD, HEADING_RAD, n)


def behind_cuboid(cfg: dict, offset: np.ndarray, heading: np.ndarray) -> dict[str, torch.Tensor]:
    """Robots right behind the object's -x face (2 cm between), facing +x up to `heading`, shifted by `offset`."""
    hull = np.asarray(object_hull(cfg["task"]["object"]))
    n = len(offset)
    gap = float(-hull[:, 0].min()) + cfg["lowlevel"]["size"][0] / 2 + 0.02
    robot = np.stack([np.full(n, -gap), offset], -1)[:, None, :]
    return {
        "object_xy": torch.zeros(n, 2),
        "object_yaw": torch.zeros(n),
        "robot_xy": torch.from_numpy(robot).float(),
        "robot_yaw": torch.from_numpy(heading[:, None]).float(),
        "subgoal_xy": torch.tensor([9.0, 0.0]).expand(n, 2).clone(),
        "friction": torch.full((n,), DRAG_FRICTION),
    }


def push_sweep(overrides: list[str], repeats: int, seed: int, probe=None) -> dict[str, np.ndarray]:
    """The robot of `overrides` walking into the cuboid at every drag of `DRAG_GRID`, `repeats` starts each:
    `drag` (E,) N, `speed` (E,) the object's steady speed, m/s, `fell` (E,) whether the robot fell. `probe` (a
    tracker's `consistency.HazardProbe`) records its fall hazard."""
    cfg = to_plain(compose_config([*overrides, "task=cuboid", "task.num_agents=1"]))
    drag = np.repeat(DRAG_GRID, repeats)
    offset, heading = starts(len(drag), seed)

    def set_drag(sim) -> None:
        sim.set_object_mass(np.arange(len(drag)), drag / (DRAG_FRICTION * G))

    commands = np.tile([PUSH_SPEED, 0.0, 0.0], (len(drag), 1))
    hooks = {"during": probe.during, "after": probe.after} if probe is not None else {}
    run = run_steps(cfg, commands, behind_cuboid(cfg, offset, heading), SETTLE_S, PUSH_S, configure=set_drag, **hooks)
    tail = max(1, round(STEADY_S / run["dt"]))
    return {
        "drag": drag,
        "speed": run["object_speed"][:, -tail:].mean(1),
        "fell": (run["tilt"] > FALL_TILT).any(1),
        "object_speed": run["object_speed"],
        "dt": run["dt"],
    }


def fall_sweep(overrides: list[str], repeats: int, seed: int, probe=None) -> dict[str, np.ndarray]:
    """The robot of `overrides` walking at `PUSH_SPEED` under each held load of `LOAD_GRID`, `repeats` starts each,
    for `FALL_WINDOW_S`: `load` (E,) N and `fell` (E,). `probe` as `push_sweep`'s."""
    cfg = to_plain(compose_config([*overrides, "task=cuboid", "task.num_agents=1"]))
    load = np.repeat(LOAD_GRID, repeats)
    _, heading = starts(len(load), seed + 1)
    layout = {
        "object_xy": torch.tensor(PARKED_XY).expand(len(load), 2).clone(),
        "object_yaw": torch.zeros(len(load)),
        "robot_xy": torch.zeros(len(load), 1, 2),
        "robot_yaw": torch.from_numpy(heading[:, None]).float(),
        "subgoal_xy": torch.tensor(PARKED_XY).expand(len(load), 2).clone(),
        "friction": torch.full((len(load),), DRAG_FRICTION),
    }
    back = -load[:, None] * np.stack([np.cos(heading), np.sin(heading)], -1)  # (E, 2) N, against the start heading

    def hold_load(sim) -> None:
        if not hasattr(sim, "_calibration_load"):
            sim._calibration_load = sim.batch.bind("xfrc_applied")
        body = sim.model.body(ROBOT_PREFIX.format(0) + _root_body(cfg)).id
        sim._calibration_load[:, body, :2] = back
        if probe is not None:
            probe.during(sim)

    commands = np.tile([PUSH_SPEED, 0.0, 0.0], (len(load), 1))
    after = probe.after if probe is not None else None
    run = run_steps(cfg, commands, layout, SETTLE_S, FALL_WINDOW_S, during=hold_load, after=after)
    return {"load": load, "fell": (run["tilt"] > FALL_TILT).any(1)}


def _root_body(cfg: dict) -> str:
    """The body a held load acts on: the Go1's trunk, the tracker's one body."""
    from mapush.lowlevel import backend_name, go1_constants
    from mapush.lowlevel.tracker import ROBOT_BODY

    return go1_constants.ROOT_BODY if backend_name(cfg["lowlevel"]) == "go1" else ROBOT_BODY


def fit_capacity(drag: np.ndarray, speed: np.ndarray, stall: float = STALL_SPEED) -> float | None:
    """The drag (N) at which the median steady object speed first falls to `stall`, interpolated linearly between
    the grid's drags; None when it never does (the capacity is beyond the grid)."""
    grid = np.unique(drag)
    median = np.array([np.median(speed[drag == d]) for d in grid])
    below = np.flatnonzero(median <= stall)
    if len(below) == 0:
        return None
    k = int(below[0])
    if k == 0:
        return float(grid[0])
    d0, d1, v0, v1 = grid[k - 1], grid[k], median[k - 1], median[k]
    return float(d0 + (v0 - stall) / (v0 - v1) * (d1 - d0))


def fit_push_gain(
    drag: np.ndarray, speed: np.ndarray, command: float = PUSH_SPEED, stall: float = STALL_SPEED
) -> float | None:
    """The push gain k (N per m/s) of the line drag = k (command - speed) through the median steady speeds that
    still move the object (above `stall`), least squares through the origin; None with fewer than two such drags."""
    grid = np.unique(drag)
    median = np.array([np.median(speed[drag == d]) for d in grid])
    moving = median > stall
    if moving.sum() < 2:
        return None
    shortfall = command - median[moving]
    return float((grid[moving] * shortfall).sum() / (shortfall**2).sum())


def fall_overrides(fall: dict | None) -> list[str]:
    """The Hydra overrides that make `fall` the tracker's whole fall model (None: it cannot fall): the config's model
    cleared, then this one set, so that no key of the config's (a shove curve) is merged into it."""
    if fall is None:
        return ["lowlevel.fall=null"]
    return ["lowlevel.fall=null", "++lowlevel.fall={" + ",".join(f"{k}:{v:g}" for k, v in fall.items()) + "}"]


def fall_probability(load: np.ndarray, load_n: float, width_n: float) -> np.ndarray:
    """The logistic fall curve P(L) within the window."""
    return 1.0 / (1.0 + np.exp(-np.clip((np.asarray(load, dtype=np.float64) - load_n) / width_n, -60, 60)))


def fit_fall_curve(load: np.ndarray, fell: np.ndarray) -> dict[str, float] | None:
    """The logistic (`load_n`, `width_n`, N) of greatest likelihood for the falls `fell` (E,) under `load` (E,),
    over a grid fine to 0.25 % of the loads' span; None when nothing fell (no fall curve to fit)."""
    if not fell.any():
        return None
    grid, where = np.unique(load, return_inverse=True)
    falls = np.bincount(where, weights=fell.astype(float))  # per load: falls of trials
    trials = np.bincount(where).astype(float)
    span = float(grid[-1] - grid[0]) or 1.0
    centres = np.linspace(grid[0] - span, grid[-1] + span, 1201)
    widths = np.geomspace(span / 400, span, 120)
    z = (grid[None, None, :] - centres[:, None, None]) / widths[None, :, None]
    p = np.clip(1.0 / (1.0 + np.exp(-np.clip(z, -60, 60))), 1e-12, 1 - 1e-12)
    ll = (falls * np.log(p) + (trials - falls) * np.log1p(-p)).sum(-1)
    i, j = np.unravel_index(int(ll.argmax()), ll.shape)
    return {"load_n": float(centres[i]), "width_n": float(widths[j])}
