"""Falls under a squeeze: whether a robot pinned between the object and its teammates' pushes topples.

Every robot walks into the cuboid at `PUSH_SPEED` for `SQUEEZE_S`, in each of these layouts (robot 0 first):
- *alone*: right behind the cuboid, held immovable (`WALL_DRAG`, far beyond any robot's capacity): the robot bears
  its own push and nothing more, the reference;
- *run-up*: the same, from `RUN_UP_M` further back: the robot meets the object at full speed, an impact;
- *in a line*: the same, with one or two teammates in a line behind it, each walking into the back of the one
  ahead: the front robot is squeezed between the object and its teammates' pushes;
- *across*: one teammate on the cuboid's far face, walking the other way, the cuboid at `ACROSS_DRAG` (the cuboid
  task's own): each robot bears the other's push through the object, as at the two sides of the cylinder;
- *2 against 1*: two teammates side by side on the far face: they outpush the robot, which is shoved back.

And a graded shove (`shove_sweep`): "2 against 1", the pair told each speed of `PAIR_SPEEDS` and robot 0 the full
`PUSH_SPEED`: from a pair that robot 0 outpushes to one that drives it back.

A robot that tilts beyond the pushing levels' `robot_tilt` threshold has fallen. The tracker's fall model reads the
net planar contact force on it, in which pushes from opposite sides cancel (docs/fidelity.md, "Known open
deviations"); this measures whether the Go1 falls there, so the two can be compared (`mapush probe squeeze`).
"""

from __future__ import annotations

import numpy as np
import torch

from mapush.calibration.capacity import DRAG_FRICTION, FALL_TILT, PUSH_SPEED, SETTLE_S, G, behind_cuboid, starts
from mapush.calibration.lags import run_steps
from mapush.config import compose_config, to_plain

LAYOUTS = ("alone", "run-up", "line of 2", "line of 3", "across", "2 against 1")
"""The squeezes measured, from none to the most robots bearing on one."""
WALL_DRAG = 400.0
"""N; the cuboid's drag in the line layouts: about 8 times a Go1's push capacity (52 N), so it does not move."""
ACROSS_DRAG = 12.0
"""N; the cuboid's drag across: its task's (4 kg at 0.3 friction; docs/fidelity.md)."""
SQUEEZE_S = 6.0
"""s; how long each squeeze lasts."""
RUN_UP_M = 1.0
"""m; how much further back the run-up starts: the Go1 reaches a 0.5 m/s step within 0.5 s and 0.2 m
(results/calibration/), so it meets the object at full speed."""
SIDE_BY_SIDE = torch.tensor([0.0, 0.25])
"""m; the two robots of "2 against 1" stand this far to either side of the far face's centre line (0.5 m apart,
a robot's footprint is 0.28 m wide; the cuboid's face is 1.2 m)."""
PAIR_SPEEDS = (0.1, 0.2, 0.3, 0.4, 0.5)
"""m/s; the pair's commands in the graded shove, up to the full `PUSH_SPEED`."""
SHOVE_SPEED_S = (1.0, 2.0)
"""s into the hold; robot 0's speed along its heading is averaged between them, after the pair has closed in."""
SHOVE_SCALES = np.linspace(0.01, 0.5, 197)
"""m/s; the shove curve's scales the fit tries: from a creep to the full `PUSH_SPEED`."""
SHOVE_SHAPES = np.geomspace(1.0, 40.0, 60)
"""The shove curve's shapes the fit tries: from a hazard growing in proportion to u to a step at the scale."""
GAP_M = 0.02
"""m; between the object and the first robot, and between robots in a line."""


def _layout(cfg: dict, name: str, n: int, seed: int) -> tuple[dict[str, torch.Tensor], float]:
    """The robots of layout `name` in n envs (starts drawn from `seed`), and the cuboid's drag (N)."""
    offset, heading = starts(n, seed)
    layout = behind_cuboid(cfg, offset, heading)
    agents = int(cfg["task"]["num_agents"])
    front, yaw = layout["robot_xy"], layout["robot_yaw"]
    if name in ("across", "2 against 1"):
        far = front * torch.tensor([-1.0, 1.0])  # mirrored onto the +x face
        if name == "2 against 1":  # two side by side there
            far = torch.cat([far - SIDE_BY_SIDE, far + SIDE_BY_SIDE], 1)
        layout["robot_xy"] = torch.cat([front, far], 1)
        layout["robot_yaw"] = torch.cat([yaw, (np.pi - yaw).expand(n, agents - 1)], 1)
        return layout, drag_of(name)
    if name == "run-up":
        front = front - torch.tensor([RUN_UP_M, 0.0])
    step = torch.tensor([cfg["lowlevel"]["size"][0] + GAP_M, 0.0])
    layout["robot_xy"] = torch.cat([front - k * step for k in range(agents)], 1)
    layout["robot_yaw"] = yaw.expand(n, agents).clone()
    return layout, drag_of(name)


def agents_of(name: str) -> int:
    """How many robots layout `name` has."""
    return {"across": 2, "2 against 1": 3}.get(name) or (int(name.split()[-1]) if name.startswith("line") else 1)


def _with_drag(n: int, drag: float):
    """A `configure` for `run_steps`: the cuboid's floor drag `drag` (N) in all n envs."""

    def set_drag(sim) -> None:
        sim.set_object_mass(np.arange(n), np.full(n, drag / (DRAG_FRICTION * G)))

    return set_drag


def squeeze_sweep(overrides: list[str], envs: int, seed: int, layouts=LAYOUTS, probes=None) -> dict:
    """The robot of `overrides` in each of `layouts`, `envs` starts each: `layout` (L,); `fell` (L,), the share of
    starts in which a robot fell within `SQUEEZE_S`, and `first_fell` (L,), in which robot 0 did (the one squeezed
    against the object, or shoved back). `probes`: one recorder per layout (a tracker's `consistency.HazardProbe`)."""
    fell, first_fell = [], []
    for k, name in enumerate(layouts):
        cfg = to_plain(compose_config([*overrides, "task=cuboid", f"task.num_agents={agents_of(name)}"]))
        layout, drag = _layout(cfg, name, envs, seed)
        commands = np.tile([PUSH_SPEED, 0.0, 0.0], (envs, 1))
        probe = probes[k] if probes is not None else None
        hooks = {"during": probe.during, "after": probe.after} if probe is not None else {}
        run = run_steps(cfg, commands, layout, SETTLE_S, SQUEEZE_S, configure=_with_drag(envs, drag), **hooks)
        fell.append(float((run["tilt"] > FALL_TILT).any(1).mean()))
        first_fell.append(float((run["tilts"][..., 0] > FALL_TILT).any(1).mean()))
    return {"layout": list(layouts), "fell": np.array(fell), "first_fell": np.array(first_fell), "envs": envs}


def _graded_shove(
    overrides: list[str], envs: int, seed: int, pair_speeds, after=None, during=None
) -> dict[str, np.ndarray]:
    """`run_steps` of "2 against 1", the pair told each of `pair_speeds` (`envs` starts each, in that order) and
    robot 0 the full `PUSH_SPEED`; `during(sim)` and `after(sim)` run before and after every step of the hold."""
    cfg = to_plain(compose_config([*overrides, "task=cuboid", "task.num_agents=3"]))
    n = envs * len(pair_speeds)
    layout, drag = _layout(cfg, "2 against 1", n, seed)
    commands = np.zeros((n, 3, 3))
    commands[:, 0, 0], commands[:, 1:, 0] = PUSH_SPEED, np.repeat(pair_speeds, envs)[:, None]
    return run_steps(
        cfg, commands, layout, SETTLE_S, SQUEEZE_S, configure=_with_drag(n, drag), after=after, during=during
    )


def shove_sweep(overrides: list[str], envs: int, seed: int, pair_speeds=PAIR_SPEEDS, probe=None) -> dict:
    """The robot of `overrides` shoved by a pair at each of `pair_speeds`, `envs` starts each: `pair_speed` (S,);
    `fell` (S,), the share of starts in which robot 0 fell within `SQUEEZE_S`; `speed` (S,), robot 0's median speed
    along its heading over `SHOVE_SPEED_S` (m/s; below 0: driven back). `probe`: a tracker's `HazardProbe`."""
    hooks = {"during": probe.during, "after": probe.after} if probe is not None else {}
    run = _graded_shove(overrides, envs, seed, pair_speeds, **hooks)
    first, last = (round(s / run["dt"]) for s in SHOVE_SPEED_S)
    fell = (run["tilts"][..., 0] > FALL_TILT).any(1).reshape(len(pair_speeds), envs)
    speed = run["robot_vel"][:, first:last, 0].mean(1).reshape(len(pair_speeds), envs)
    return {"pair_speed": np.asarray(pair_speeds, float), "fell": fell.mean(1), "speed": np.median(speed, 1)}


def tracker_shoves(overrides: list[str], envs: int, seed: int, pair_speeds=PAIR_SPEEDS) -> dict[str, np.ndarray]:
    """The tracker of `overrides` (a `fall` model with shove keys; their values do not matter: a fall changes no
    motion) in the graded shove, as `shove_sweep` runs it: robot 0's low-passed shove speed `shove` (E, T), m/s, and
    its hazard rate from the contact load `load_rate` (E, T), 1/s, at every policy step; `group` (E,) the index of
    its pair speed; `dt`, s."""
    shove, load_rate = [], []

    def record(sim) -> None:
        robots = sim.lowlevel
        shove.append(robots.shove[:, 0].copy())
        load_rate.append(robots.load_rate(robots.load[:, 0]))

    run = _graded_shove(overrides, envs, seed, pair_speeds, after=record)
    return {
        "shove": np.stack(shove, 1),
        "load_rate": np.stack(load_rate, 1),
        "group": np.repeat(np.arange(len(pair_speeds)), envs),
        "dt": run["dt"],
    }


def fit_shove_curve(traces: dict[str, np.ndarray], falls: np.ndarray, trials: np.ndarray, window_s: float):
    """The shove curve (`shove_mps`, `shove_shape`: P(u) = 1 - exp(-(u / shove_mps) ** shove_shape) within
    `window_s`) of greatest likelihood for the Go1's `falls` of `trials` (S,) per pair speed, when the tracker's fall
    share at each is the mean over its starts of 1 - exp(-H), H its hazard (the contact load's and the shove
    curve's) integrated over the hold (`tracker_shoves`' `traces`); None when no Go1 fell, or the tracker was never
    shoved where one did (the likelihood would be flat)."""
    shove, group, dt = traces["shove"], traces["group"], traces["dt"]
    fell_where = np.isin(group, np.flatnonzero(falls))
    if not fell_where.any() or not shove[fell_where].max() > 0:  # no fall, or no shove where the Go1 fell to fit to
        return None
    load_hazard = traces["load_rate"].sum(1) * dt  # (E,)
    scales = SHOVE_SCALES[:, None, None]
    best = (-np.inf, None)
    for shape in SHOVE_SHAPES:
        hazard = load_hazard[None] + ((shove[None] / scales) ** shape).sum(-1) * dt / window_s  # (M, E)
        fell = 1.0 - np.exp(-hazard)
        share = np.stack([fell[:, group == s].mean(1) for s in range(len(falls))], 1).clip(1e-9, 1 - 1e-9)  # (M, S)
        ll = (falls * np.log(share) + (trials - falls) * np.log1p(-share)).sum(1)
        if ll.max() > best[0]:
            scale = float(scales[int(ll.argmax()), 0, 0])
            best = (float(ll.max()), {"shove_mps": scale, "shove_shape": float(shape)})
    return best[1]


def shove_at_grid_bound(curve: dict[str, float]) -> str | None:
    """What a fitted shove curve on an edge of the fit's grid means (a bound, not a fit), or None inside it."""
    edges = [
        f"{key} {curve[key]:g} is the fit grid's {'lower' if np.isclose(curve[key], grid[0]) else 'upper'} bound"
        for key, grid in (("shove_mps", SHOVE_SCALES), ("shove_shape", SHOVE_SHAPES))
        if np.isclose(curve[key], grid[0]) or np.isclose(curve[key], grid[-1])
    ]
    return "; ".join(edges) or None


def drag_of(name: str) -> float:
    """N; the cuboid's drag in layout `name`: immovable against a wall of robots, its task's across it."""
    return ACROSS_DRAG if name in ("across", "2 against 1") else WALL_DRAG


def print_squeeze(overrides: list[str], envs: int, seed: int) -> None:
    """`mapush probe squeeze`: the layouts, one line each, then the graded shove, one line per pair speed."""
    found = squeeze_sweep(overrides, envs, seed)
    robot = " ".join(overrides) or "the default low level"
    print(f"{robot}: {envs} starts a layout, {SQUEEZE_S:g} s walking into the cuboid at {PUSH_SPEED:g} m/s")
    print(f"{'layout':>11s} {'robots':>6s} {'drag N':>7s} {'robot 0 fell':>12s} {'a robot fell':>12s}")
    for name, first, fell in zip(found["layout"], found["first_fell"], found["fell"], strict=True):
        print(f"{name:>11s} {agents_of(name):6d} {drag_of(name):7g} {first:12.2f} {fell:12.2f}")
    shoved = shove_sweep(overrides, envs, seed)
    print(f"2 against 1, graded: robot 0 at {PUSH_SPEED:g} m/s, the pair at each speed; robot 0's speed along its")
    print(f"heading over {SHOVE_SPEED_S[0]:g}-{SHOVE_SPEED_S[1]:g} s (median; below 0: driven back)")
    print(f"{'pair m/s':>11s} {'speed m/s':>10s} {'robot 0 fell':>12s}")
    for pair, speed, fell in zip(shoved["pair_speed"], shoved["speed"], shoved["fell"], strict=True):
        print(f"{pair:11g} {speed:10.2f} {fell:12.2f}")
