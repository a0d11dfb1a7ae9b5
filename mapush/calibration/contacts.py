"""How a robot pushes: which of its parts touch the object, how hard, and how fast the object goes for it.

One robot starts right behind the object (the cuboid unless an override names another task; the task's own mass,
its floor friction the middle of the task's range) and walks into it at each command speed for `PUSH_S`. After
every physics step (not only every policy step: a swinging leg's contact lasts a few of them) the contact forces on
the object are read and added up per robot part (the body's name less the robot's and the leg's prefix: `trunk`,
`hip`, `thigh`, `calf` for the Go1, whose foot is part of its calf; `base` for the tracker), with the floor's beside
them. The first `SETTLE_IN_S` of each push, while the robot reaches the object, is left out.

Reported per speed: the object's speed (mean, 99th percentile, largest) against the command, and per part the share
of physics steps it touches the object, its mean, 99th-percentile and largest push along the command, and its share
of the push in the policy steps that sped the object up most (`SPEED_UP_QUANTILE`). At a steady push the robot's
mean force equals the floor's drag; the two are printed together as a check of the reading.

The copy of an env's data that `Batch.get_data` gives holds its state but no contacts, so each env's contacts are
found and solved again (`mj_forward`) on that copy with the env's own model values (`Batch.get_model`: its
friction, the tracker's force caps), one env at a time: a probe, never a training step.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mapush.calibration.capacity import SETTLE_S, behind_cuboid, starts
from mapush.calibration.lags import run_steps
from mapush.config import compose_config, to_plain
from mapush.lowlevel.go1_constants import LEGS
from mapush.sim.scene import OBJECT_BODY, ROBOT_PREFIX

PUSH_S = 6.0
"""s; how long each push lasts."""
SETTLE_IN_S = 1.0
"""s; the start of each push left out: the robot walks up to the object and meets it."""
SPEED_UP_QUANTILE = 99.0
"""The policy steps whose gain in object speed is above this percentile count as the object's jolts."""
FLOOR = "floor"
"""The part name of the world's geoms (the floor): the drag the robot's push works against."""


def part_name(body: str) -> str:
    """A body's part name: a robot body's name less its robot prefix and its leg's (`robot0/FR_calf` -> `calf`)."""
    name = body.split("/", 1)[-1]
    return next((name[len(leg) + 1 :] for leg in LEGS if name.startswith(f"{leg}_")), name)


class ContactLog:
    """A `substep` hook of `run_steps`: the world-x force on the object from the floor and each part of robot 0,
    per env, after every physics step (`rows`, each (E, P), in the order of `parts`)."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.parts: list[str] = []
        self.of_body = np.empty(0, dtype=np.int64)  # each body's index in `parts`, -1 for none

    def __call__(self, sim) -> None:
        if not self.parts:
            model = sim.model
            names = {b: part_name(model.body(b).name) for b in range(model.nbody)
                     if model.body(b).name.startswith(ROBOT_PREFIX.format(0))}  # fmt: skip
            self.parts = [FLOOR, *sorted(set(names.values()))]
            self.of_body = np.full(model.nbody, -1)
            self.of_body[0] = 0  # the world body holds the floor
            for b, name in names.items():
                self.of_body[b] = self.parts.index(name)
        self.rows.append(object_forces(sim, len(self.parts), self.of_body))


def object_forces(sim, parts: int, part_of_body: np.ndarray) -> np.ndarray:
    """(E, parts) N: the world-x force on the object from each part (`part_of_body[body]` is its index, -1 for a
    body left out), summed over each env's contacts now."""
    model, obj = sim.model, sim.model.body(OBJECT_BODY).id
    out = np.zeros((sim.num_envs, parts))
    force = np.zeros(6)
    for env in range(sim.num_envs):
        own, data = sim.batch.get_model(env), sim.batch.get_data(env)
        mujoco.mj_forward(own, data)
        for k in range(data.ncon):
            contact = data.contact[k]
            b1, b2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
            if obj not in (b1, b2):
                continue
            other = b1 if b2 == obj else b2
            if part_of_body[other] < 0:
                continue
            mujoco.mj_contactForce(own, data, k, force)
            on_geom2 = contact.frame.reshape(3, 3).T @ force[:3]  # the frame's normal points from geom1 to geom2
            out[env, part_of_body[other]] += on_geom2[0] if b2 == obj else -on_geom2[0]
    return out


def contact_sweep(overrides: list[str], speeds: list[float], repeats: int, seed: int) -> list[dict]:
    """The robot of `overrides` pushing the object (the cuboid unless they name a task) at each of `speeds` (m/s),
    `repeats` starts each. Per speed: `speed`; `object_speed` (E, T), m/s at every policy step; `force` (E, S, P),
    N at every physics step from each of `parts` (P,); `substeps`, physics steps per policy step (S = T x it)."""
    task = [] if any(o.startswith("task=") for o in overrides) else ["task=cuboid"]
    cfg = to_plain(compose_config([*task, *overrides, "task.num_agents=1"]))
    offset, heading = starts(repeats, seed)
    layout = behind_cuboid(cfg, offset, heading)
    layout["friction"][:] = float(np.mean(cfg["task"]["object"]["friction"]))
    found = []
    for speed in speeds:
        log = ContactLog()
        commands = np.tile([speed, 0.0, 0.0], (repeats, 1))
        run = run_steps(cfg, commands, layout, SETTLE_S, PUSH_S, substep=log)
        substeps = len(log.rows) // run["object_speed"].shape[1]
        skip = round(SETTLE_IN_S / run["dt"])
        found.append({
            "speed": speed,
            "object_speed": run["object_speed"][:, skip:],
            "force": np.stack(log.rows, 1)[:, skip * substeps :],
            "parts": log.parts,
            "substeps": substeps,
        })  # fmt: skip
    return found


def jolt_shares(push: dict) -> np.ndarray:
    """(P,) each part's share of the push along the command in the policy steps whose gain in object speed is above
    `SPEED_UP_QUANTILE`: who drives the object's jolts."""
    speed, force, k = push["object_speed"], push["force"], push["substeps"]
    steps = speed.shape[1] - 1
    impulse = force[:, k : (steps + 1) * k].reshape(len(force), steps, k, -1).sum(2)  # (E, T-1, P), the step's push
    gain = np.diff(speed, axis=1)
    top = gain > np.percentile(gain, SPEED_UP_QUANTILE)
    pushing = np.array([p != FLOOR for p in push["parts"]])
    total = impulse[top][:, pushing].sum()
    return np.where(pushing, impulse[top].sum(0) / total if total > 0 else 0.0, np.nan)


def print_contacts(overrides: list[str], speeds: list[float], repeats: int, seed: int) -> None:
    """`mapush probe contacts`: per speed, the object's speed, then one line per part."""
    robot = " ".join(overrides) or "the default low level"
    print(f"{robot}: {repeats} starts a speed, pushing the object for {PUSH_S:g} s (the first {SETTLE_IN_S:g} s left "
          "out); forces along the command, read at every physics step")  # fmt: skip
    for push in contact_sweep(overrides, speeds, repeats, seed):
        v, f = push["object_speed"], push["force"]
        print(f"command {push['speed']:g} m/s: object speed mean {v.mean():.2f}, p99 {np.percentile(v, 99):.2f}, "
              f"largest {v.max():.2f} m/s")  # fmt: skip
        print(f"  {'part':>8s} {'touching':>8s} {'mean N':>7s} {'p99 N':>7s} {'max N':>7s} {'jolts':>6s}")
        shares = jolt_shares(push)
        for k, part in enumerate(push["parts"]):
            column = f[..., k]
            if part == FLOOR:  # its drag, for the balance: its other columns would describe its contact points
                print(f"  {part:>8s} {'':>8s} {column.mean():7.1f}")
                continue
            print(f"  {part:>8s} {(np.abs(column) > 1e-9).mean():8.2f} {column.mean():7.1f} "
                  f"{np.percentile(column, 99):7.1f} {column.max():7.1f} {shares[k]:6.2f}")  # fmt: skip
