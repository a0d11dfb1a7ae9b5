"""What the measuring and inspecting commands do (`mapush.cli.tools` reads their arguments): bench, plan, calibrate,
plot, list."""

from __future__ import annotations

from pathlib import Path

from mapush.commands.arguments import number_list, output_dir, output_file
from mapush.errors import BadInput


def bench(overrides: list[str], json_path: Path | None, learn: bool, minutes: float, video: bool, out: Path) -> None:
    """`mapush bench`: throughput and an iteration's phases, with `learn` the minutes to a given success, with
    `video` the time of a headless video; printed as JSON and written to `json_path`."""
    import json
    import sys

    if json_path:
        output_file(json_path, "--json")
    if video:
        output_file(out, "--out")
        if learn:
            raise BadInput("--video and --learn measure different things; valid: one of them")
        from mapush.viz.preflight import require_offscreen_gl

        require_offscreen_gl()  # before MuJoCo is imported: it picks the OpenGL backend
    from mapush import bench as benchmarks
    from mapush.config import compose_config

    if video:  # its own episode: shipped:cuboid's first of seed 0 (`mapush.bench.rendering.TARGET`), the overrides
        result = benchmarks.run_video_bench(overrides, out, " ".join(["mapush", *sys.argv[1:]]))
    else:
        cfg = compose_config(overrides)
        if learn:
            if minutes <= 0:
                raise BadInput(f"--minutes {minutes} must be positive; valid: a number of minutes > 0")
            result = benchmarks.run_learning_bench(cfg, overrides, minutes, Path(cfg.bench.learn.run_root))
        else:
            result = benchmarks.run_bench(cfg)
    text = json.dumps(result, indent=2)
    print(text)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(text + "\n")
        if learn:
            benchmarks.learning.plot_learning(result, json_path.with_suffix(".png"))


def plan(overrides: list[str], task: str, seed: int, json_path: Path | None, png: Path | None, maps: int) -> None:
    """`mapush plan`: the object's path through the random map of `seed`, printed, written as JSON and drawn;
    with `maps` > 1, the planner's timing over that many maps."""
    import json

    if maps < 1:
        raise BadInput(f"--maps {maps} must be 1 or more")
    for path, flag in ((json_path, "--json"), (png, "--png")):
        if path is not None:
            output_file(path, flag)
    from mapush.config import compose_config, to_plain

    cfg = to_plain(compose_config(["level=high", f"task={task}", f"seed={seed}", *overrides]))
    from mapush.commands import plan as planning  # after the checks: the planner and the envs take seconds to import
    from mapush.envs.resets import make_planner

    planner = make_planner(cfg)
    try:
        record, _ = planning.plan_map(cfg, seed, planner)
        state = "valid" if record["valid"] else ("INVALID" if record["solved"] else "no path found (planner failure)")
        print(
            f"{task} seed {seed}: {record['planner']} path {record['length_m']:.2f} m, "
            f"{1000 * record['planning_time_s']:.1f} ms, {len(record['obstacles'])} obstacles, {state}"
        )
        if maps > 1:
            t = planning.timing(cfg, seed, maps, planner)
            print(
                f"{t['maps']} maps: median {1000 * t['median_s']:.1f} ms, max {1000 * t['max_s']:.1f} ms; "
                f"validity checks median {t['median_checks']:.0f}, max {t['max_checks']} "
                f"(budget {cfg['level']['planner']['max_checks']}); stopped by the clock {t['wall_clock_stops']}; "
                f"solved {t['solved']}, valid {t['valid']}"
            )
            record["timing"] = t
    finally:
        planner.close()
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(record, indent=2) + "\n")
        print(json_path)
    if png:
        print(planning.draw(cfg, record, png))


def calibrate(
    overrides: list[str],
    steps: str,
    settle: float,
    duration: float,
    repeats: int,
    seed: int,
    out: Path | None,
    name: str,
    config: Path | None,
) -> None:
    """`mapush calibrate`: measure the low level of `overrides` (default lowlevel=go1) and write the tracker that
    stands for it, OUT/lowlevel/NAME.yaml; print the fitted values and how to use it."""
    import datetime

    if config is not None:
        raise BadInput(
            f"--config {config}: calibrate no longer rewrites a tracker config; valid: --name NAME, which writes "
            "OUT/lowlevel/NAME.yaml for mapush train lowlevel=NAME 'hydra.searchpath=[file://OUT]'"
        )
    step_sizes = number_list(steps, "--steps", kind=float, minimum=1e-3)
    if settle < 0 or duration <= 0:
        raise BadInput(f"--settle {settle} / --duration {duration}: valid: settle >= 0, duration > 0 seconds")
    if repeats < 1:
        raise BadInput(f"--repeats {repeats}: valid: 1 or more")
    from mapush.calibration.tracker_option import check_name, use_line

    check_name(name)  # a name it cannot write as a tracker option, before anything is measured
    reference = overrides if any(o.startswith("lowlevel=") for o in overrides) else ["lowlevel=go1", *overrides]
    stamp = datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    out_dir = output_dir(out or Path("runs") / "calibrate" / stamp, "--out")
    from mapush.calibration.run import calibrate as run_calibration  # after the checks: it imports the envs

    summary = run_calibration(reference, step_sizes, settle, duration, out_dir, name, repeats, seed)
    written = ", ".join(
        f"{k} {v:.4g}" if not isinstance(v, dict) else f"{k} {v}" for k, v in summary["written"].items()
    )
    print(f"capacity {summary['capacity_n']} N, fall curve {summary['fall_curve']}")
    if summary["tracker_config"]:
        print(f"wrote {written or 'no fitted value'} -> {summary['tracker_config']}")
    for warning in summary["warnings"]:
        print(f"warning: {warning}")
    if summary["tracker_config"]:
        print(use_line(name, out_dir))
    print(out_dir)


def plot(run_dirs: list[Path], out: Path | None, smooth: int) -> None:
    """`mapush plot`: learning curves of `run_dirs` as a PNG (default: RUN_DIR/curves.png, or ./curves.png)."""
    from mapush.commands.plot import plot_runs

    if out is None:
        out = run_dirs[0] / "curves.png" if len(run_dirs) == 1 else Path("curves.png")
    print(plot_runs(run_dirs, output_file(out, "-o"), smooth))


def list_choices() -> None:
    """`mapush list`: the config groups and their options, the trusted code, the shipped policies."""
    from mapush.config import GROUPS, group_options
    from mapush.rundir import shipped_names
    from mapush.trust import trusted_modules

    for group in (*GROUPS, "method", "experiment", "launcher"):  # the last three: `mapush sweep`'s groups
        print(f"{group + ':':<12}{', '.join(group_options(group))}")
    print(
        f"{'shipped:':<12}{', '.join(shipped_names())}   (mapush eval shipped:NAME, mapush.load_policy('shipped:NAME'))"
    )
    print(f"{'trusted:':<12}{', '.join(trusted_modules())}   (more with mapush --trust MODULE)")
