"""`mapush calibrate`: measure a legged low level and write the tracker that stands for it.

Three experiments on the robot that the overrides choose (default `lowlevel=go1`, its shipped policy):
- free step responses -> the tracker's `yaw_lag` (`lags.py`); the linear steps' own first-order fit is reported;
- walking into a cuboid of growing drag -> its push capacity, the tracker's `max_force` on the planar norm, and its
  force-speed line, whose push gain sets the tracker's `lag` = mass / gain (`capacity.py`): the tracker's velocity
  actuator F = gain (v_cmd - v) is that line, so it pushes each drag at the Go1's speed;
- walking under a growing held load -> its fall curve; the tracker's held-load channel is fitted to those falls on
  the tracker's own load in the same starts (`consistency.fit_held_curve`);
- pinned by teammates in six layouts, and shoved back through the cuboid by two teammates walking at growing speeds
  -> its falls (`squeeze.py`); the tracker's contact fall curve takes the held-load curve's width and the lowest
  midpoint at which it falls, in the push sweep, the squeezes and the shoves, no more than 10 points more often than
  the Go1 (`consistency.fit_contact_midpoint`); a shove curve (`shove_mps`, `shove_shape`) is fitted where the Go1
  fell when shoved.

Then the tracker as it would be written runs every test with a fall outcome, and its expected falls are held
against the Go1's, group by group (`consistency.compare`): a tracker more than 10 points apart anywhere is not
written, and each failing group is reported.
The fitted values replace those keys of the package's tracker config in a tracker of its own, `lowlevel/<name>.yaml`
in the output dir (`tracker_option.py`), except a yaw lag the robot does not follow (`STEADY_MIN`), a capacity or
push gain the sweep cannot give, or a fall curve with no fall, which are reported instead and stay as they were; a
yaw lag at the fit grid's bound is written and reported (the robot turns at least that quickly). The package's own
config is never written. `calibration.json` (every measurement) and `calibration.png` (the robot's responses against
the fitted tracker's) go to the output dir too.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from mapush.atomic import write_text
from mapush.calibration import capacity as cap
from mapush.calibration import consistency, squeeze
from mapush.calibration.lags import (
    AXES,
    LAG_GRID,
    STEADY_MIN,
    at_grid_bound,
    fit_lag,
    free_layout,
    run_steps,
    steady_fractions,
    step_commands,
)
from mapush.calibration.tracker_option import DEFAULT_NAME, check_name, default_config_path, write_tracker_option
from mapush.config import compose_config, to_plain
from mapush.lowlevel.go1 import policy_of

SHOVE_STARTS_PER_REPEAT = 16
"""Starts per pair speed in the graded shove and per squeeze layout, per `repeats`: 96 at the default 6, so that a
fall share's standard error (at most 5 points) is half the consistency check's tolerance (10 points)."""


def calibrate(
    reference: list[str],
    steps: list[float],
    settle_s: float,
    duration_s: float,
    out_dir: Path,
    name: str = DEFAULT_NAME,
    repeats: int = 6,
    seed: int = 0,
) -> dict:
    """Run the experiments, fit, write the tracker `out_dir/lowlevel/<name>.yaml` (if it falls as the robot does),
    `calibration.json` and `calibration.png`; `summary["tracker_config"]` is the tracker's path (None: not written).

    Args:
        reference: overrides that select the robot to measure, e.g. `["lowlevel=go1", "lowlevel.policy=P"]`.
        repeats: starts per drag and per load in the capacity and fall sweeps. seed: draws those starts.
    """
    check_name(name)  # before hours of measuring
    out_dir.mkdir(parents=True, exist_ok=True)
    robot_overrides = [*reference, "task.num_agents=1"]
    robot = to_plain(compose_config(robot_overrides))["lowlevel"]
    source = f"{robot['name']}, policy {policy_of(robot)}" if "policy" in robot else robot["name"]
    # free step responses -> lags
    free_cfg = to_plain(compose_config(robot_overrides))
    commands = step_commands(steps)
    free = run_steps(free_cfg, commands, free_layout(len(commands), 0.5), settle_s, duration_s)
    n = len(steps)
    linear = np.concatenate([free["robot_vel"][:n, :, 0], free["robot_vel"][n : 2 * n, :, 1]])
    free_lag = fit_lag(linear, np.concatenate([commands[:n, 0], commands[n : 2 * n, 1]]), free["dt"])
    yaw_lag = fit_lag(free["robot_vel"][2 * n :, :, 2], commands[2 * n :, 2], free["dt"])
    tail = max(1, round(0.5 / free["dt"]))  # steady state: the last 0.5 s
    steady = steady_fractions(free["robot_vel"], commands, tail)
    warnings = []
    fitted: dict = {}
    if steady["yaw_rate"] < STEADY_MIN:
        warnings.append(
            f"yaw_lag: the robot holds {steady['yaw_rate']:.0%} of its yaw-rate step after {duration_s:g} s, which "
            f"no first-order lag does; yaw_lag left as it was in {default_config_path()}"
        )
    else:
        fitted["yaw_lag"] = yaw_lag
        warnings += [f"yaw_lag: {why}" for why in [at_grid_bound(yaw_lag)] if why]
    # push capacity and force-speed line, and falls under a held load
    push = cap.push_sweep(reference, repeats, seed)
    capacity = cap.fit_capacity(push["drag"], push["speed"])
    gain = cap.fit_push_gain(push["drag"], push["speed"])
    falls = cap.fall_sweep(reference, repeats, seed)
    curve = cap.fit_fall_curve(falls["load"], falls["fell"])
    before = OmegaConf.to_container(OmegaConf.load(default_config_path()))  # the package's: its mass, other keys
    mass = float(before["mass"])
    if gain is None or not LAG_GRID[0] <= mass / gain <= LAG_GRID[-1]:
        warnings.append(f"lag: the push sweep gives no force-speed line (push gain {gain}); left as it was")
    else:
        fitted["lag"] = round(mass / gain, 4)
    if capacity is None:
        warnings.append(f"max_force: the robot still moves a {cap.DRAG_GRID[-1]:g} N drag; left as it was")
    else:
        fitted["max_force"] = round(capacity, 1)
    envs = SHOVE_STARTS_PER_REPEAT * repeats
    squeezes = squeeze.squeeze_sweep(reference, envs, seed)
    go1_shoves = squeeze.shove_sweep(reference, envs, seed)
    contact_load = None
    if curve is None:
        warnings.append(f"fall: no fall under loads up to {cap.LOAD_GRID[-1]:g} N; left as it was")
    else:
        # the held-load curve as its own channel; the contact curve's midpoint matched to the Go1's falls in every
        # contact test (pushing, squeezes, the graded shove), measured on the tracker as fitted so far
        width = round(curve["width_n"], 2)
        held_n = round(curve["load_n"], 1)
        model = dict(load_n=0.0, width_n=width, **cap.FALL_TIMES, held_n=held_n, held_width_n=width)
        trial = {**before, **fitted, "force_cap": "planar", "fall": model}
        measured = consistency.measure_tracker(["lowlevel=tracker", *_as_overrides(trial)], repeats, seed, envs)
        held = consistency.fit_held_curve(measured["held"], falls["fell"], cap.FALL_WINDOW_S)
        model.update({k: round(v, 2) for k, v in held.items()})
        go1 = dict(push_drag=push["drag"], push_fell=push["fell"], shove_fell=go1_shoves["fell"])
        go1.update(squeeze_first=squeezes["first_fell"], squeeze_any=squeezes["fell"])
        contact_load = consistency.fit_contact_midpoint(measured, go1, model)
        if contact_load is None:
            warnings.append("fall: the tracker falls more often than the Go1 in a contact test at every midpoint")
        else:
            fitted["fall"] = {**model, "load_n": round(contact_load, 1)}
    shoves = _fit_shoves(go1_shoves, before, fitted, envs, seed, warnings)
    # the tracker as it would be written, in every test with a fall outcome; written only if it falls as its Go1
    trial = {**before, **fitted, "force_cap": "planar"}
    written = ["lowlevel=tracker", *_as_overrides(trial)]
    measured = consistency.measure_tracker(written, repeats, seed, envs)
    expected = consistency.tracker_record(measured, len(shoves["pair_speed"]))
    shoves.update(tracker_fall_p=expected["shoves"])
    summary = {
        "fitted": {"free_lag": free_lag, "yaw_lag": yaw_lag, **{k: v for k, v in fitted.items() if k != "yaw_lag"}},
        "written": fitted,
        "capacity_n": capacity,
        "push_gain": gain,
        "fall_curve": curve,
        "contact_fall_load_n": contact_load,
        "steady_fraction": steady,
        "warnings": warnings,
        "reference": reference,
        "source": source,
        "seed": seed,
        "repeats": repeats,
        "steps": steps,
        "settle_s": settle_s,
        "duration_s": duration_s,
        "dt": free["dt"],
        "free": {"commands": commands.tolist(), "legged": free["robot_vel"].tolist()},
        "push": {
            "speed_command": cap.PUSH_SPEED,
            "drag_n": push["drag"].tolist(),
            "object_speed": push["speed"].tolist(),
            "fell": push["fell"].tolist(),
            "tracker_object_speed": measured["push_speed"].tolist(),
            "tracker_fall_p": expected["push"],
        },
        "falls": {
            "load_n": falls["load"].tolist(),
            "fell": falls["fell"].tolist(),
            "window_s": cap.FALL_WINDOW_S,
            "tracker_fall_p": expected["held"],
        },
        "squeezes": {
            "envs": envs,
            "layout": squeezes["layout"],
            "first_fell": squeezes["first_fell"].tolist(),
            "fell": squeezes["fell"].tolist(),
            "tracker_first_fell": expected["squeezes_first"],
            "tracker_fell": expected["squeezes_any"],
        },
        "shoves": shoves,
    }
    summary["consistency"] = consistency.compare(summary)
    summary["tracker_config"] = None
    if summary["consistency"]["passed"]:
        summary["tracker_config"] = str(write_tracker_option(out_dir, name, fitted, source))
    else:
        summary["written"] = {}
        warnings += [f"not written: {line}" for line in consistency.describe(summary["consistency"])]
    write_text(out_dir / "calibration.json", json.dumps(summary, indent=1) + "\n")
    plot_calibration(summary, out_dir / "calibration.png")
    return summary


def _fit_shoves(go1: dict, before: dict, fitted: dict, envs: int, seed: int, warnings: list[str]) -> dict:
    """The shove curve fitted to the robot's falls in the graded shove (`go1`, `squeeze.shove_sweep`'s) on the
    tracker as fitted so far, added to `fitted["fall"]`; what was measured, for the record."""
    record = {"envs": envs, **{key: go1[key].tolist() for key in ("pair_speed", "fell", "speed")}, "curve": None}
    model = fitted.get("fall")  # the load model just fitted (its four keys)
    if model is None:  # the fall model was left as it was (a warning says why): so is its shove curve
        return record
    unfitted = {**model, "shove_mps": 1.0, "shove_shape": 1.0}  # a fall changes no motion
    trial = {**before, **fitted, "force_cap": "planar", "fall": unfitted}
    traces = squeeze.tracker_shoves(["lowlevel=tracker", *_as_overrides(trial)], envs, seed)
    falls = np.round(go1["fell"] * envs)
    curve = squeeze.fit_shove_curve(traces, falls, np.full(len(falls), envs), float(model["window_s"]))
    if curve is None:
        warnings.append("shove: the robot never fell when shoved; the fall model is written without a shove curve")
        return record
    record["curve"] = curve
    warnings += [f"shove: {why}" for why in [squeeze.shove_at_grid_bound(curve)] if why]
    fitted["fall"] = {
        **model,
        "shove_mps": round(curve["shove_mps"], 3),
        "shove_shape": round(curve["shove_shape"], 2),
    }
    return record


def _as_overrides(tracker: dict, fall: bool = True) -> list[str]:
    """The tracker config's calibrated keys as Hydra overrides (`fall` too, unless told not)."""
    keys = ("lag", "yaw_lag", "max_force", "force_cap")
    overrides = [f"lowlevel.{k}={tracker[k]}" for k in keys]
    if fall:
        model = tracker.get("fall")
        overrides += cap.fall_overrides(model)
    return overrides


def plot_calibration(summary: dict, out: Path) -> None:
    """The measured robot (solid) against the fitted tracker (dashed): each free axis, the push capacity sweep,
    and the fall curve with its fit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 6, figsize=(24, 3.4))
    commands, legged, dt = np.array(summary["free"]["commands"]), np.array(summary["free"]["legged"]), summary["dt"]
    t = (np.arange(legged.shape[1]) + 1) * dt
    per_axis = len(commands) // 3
    for axis in range(3):
        ax = axes[axis]
        lag = summary["fitted"]["yaw_lag"] if axis == 2 else summary["fitted"].get("lag", summary["fitted"]["free_lag"])
        for k in range(axis * per_axis, (axis + 1) * per_axis):
            line = ax.plot(t, legged[k, :, axis], label=f"measured, step {commands[k, axis]:g}")[0]
            ax.plot(t, commands[k, axis] * (1 - np.exp(-t / lag)), "--", color=line.get_color())
        ax.set_title(f"free {AXES[axis]} (lag {lag:.3f} s, dashed)")
        ax.set_xlabel("s")
        ax.legend(fontsize=7)
    push = summary["push"]
    drag = np.array(push["drag_n"])
    ax = axes[3]
    for key, style, label in (("object_speed", "o-", "measured"), ("tracker_object_speed", "s--", "tracker")):
        speed = np.array(push[key])
        grid = np.unique(drag)
        ax.plot(grid, [np.median(speed[drag == d]) for d in grid], style, label=f"{label} (median)")
        ax.scatter(drag, speed, s=6, alpha=0.4)
    if summary["push_gain"] is not None:
        line = np.linspace(0.0, push["speed_command"] * summary["push_gain"], 50)
        ax.plot(
            line,
            push["speed_command"] - line / summary["push_gain"],
            "k:",
            lw=1,
            label=f"push gain {summary['push_gain']:.0f} N s/m",
        )
    if summary["capacity_n"] is not None:
        ax.axvline(summary["capacity_n"], color="k", lw=0.8, label=f"capacity {summary['capacity_n']:.1f} N")
    ax.set_title(f"walking into a load at {push['speed_command']:g} m/s")
    ax.set_xlabel("object drag, N")
    ax.set_ylabel("steady object speed, m/s")
    ax.legend(fontsize=7)
    ax = axes[4]
    load, fell = np.array(summary["falls"]["load_n"]), np.array(summary["falls"]["fell"])
    grid = np.unique(load)
    ax.plot(grid, [fell[load == x].mean() for x in grid], "o", label="measured")
    if summary["fall_curve"] is not None:
        fine = np.linspace(grid[0], grid[-1], 200)
        ax.plot(fine, cap.fall_probability(fine, **summary["fall_curve"]), "--", label="fit")
    if summary["contact_fall_load_n"] is not None:
        ax.axvline(summary["contact_fall_load_n"], color="k", lw=0.8, label="tracker's contact fall load")
    ax.set_title(f"falls within {summary['falls']['window_s']:g} s under a held load")
    ax.set_xlabel("held load, N")
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=7)
    shoves, ax = summary.get("shoves"), axes[5]
    if shoves is not None:
        ax.plot(shoves["pair_speed"], shoves["fell"], "o-", label="measured")
        for key in ("tracker_fall_p", "tracker_fell"):  # its expected falls (records before: its drawn falls)
            if key in shoves:
                ax.plot(shoves["pair_speed"], shoves[key], "s--", label="tracker as written")
                break
    ax.set_title("shoved back by two teammates: falls")
    ax.set_xlabel("the teammates' command, m/s")
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def physical_bounds() -> dict[str, tuple[float, float]]:
    """What a fitted value may be: the grids' ranges."""
    return {
        "lag": (float(LAG_GRID[0]), float(LAG_GRID[-1])),
        "yaw_lag": (float(LAG_GRID[0]), float(LAG_GRID[-1])),
        "max_force": (float(cap.DRAG_GRID[0]), float(cap.DRAG_GRID[-1])),
    }
