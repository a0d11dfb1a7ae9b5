"""Measuring and inspecting commands: bench, plan, calibrate, plot."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app, number_list, output_dir, output_file
from mapush.errors import BadInput


@app.command(context_settings=PASS_THROUGH)
def bench(
    ctx: typer.Context,
    json_path: Path | None = typer.Option(None, "--json", help="Also write the figures to this JSON file."),
    learn: bool = typer.Option(
        False,
        "--learn",
        help="Time to success: train for --minutes, evaluate checkpoints, report the minutes to "
        "bench.learn.thresholds (JSON, and a PNG beside --json).",
    ),
    minutes: float = typer.Option(10.0, "--minutes", help="--learn: wall time of training."),
    video: bool = typer.Option(
        False,
        "--video",
        help="The cost of a headless video: one whole episode of shipped:cuboid (seed 0) run with its video at the "
        "log.video defaults (or the overrides given) to --out; seconds per episode, frames.",
    ),
    out: Path = typer.Option(Path("runs/video_dev/bench.mp4"), "--out", help="--video: the MP4 to write."),
) -> None:
    """Measure throughput and where an iteration's time goes (docs/performance.md), with --learn the
    minutes of `mapush train` to a given evaluated success, or with --video the time of a headless video."""
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
        result = benchmarks.run_video_bench(list(ctx.args), out, " ".join(["mapush", *sys.argv[1:]]))
    else:
        cfg = compose_config(list(ctx.args))
        if learn:
            if minutes <= 0:
                raise BadInput(f"--minutes {minutes} must be positive; valid: a number of minutes > 0")
            result = benchmarks.run_learning_bench(cfg, list(ctx.args), minutes, Path(cfg.bench.learn.run_root))
        else:
            result = benchmarks.run_bench(cfg)
    text = json.dumps(result, indent=2)
    print(text)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(text + "\n")
        if learn:
            benchmarks.learning.plot_learning(result, json_path.with_suffix(".png"))


@app.command(context_settings=PASS_THROUGH)
def plan(
    ctx: typer.Context,
    task: str = typer.Option("cuboid", "--task", help="The object (conf/task/)."),
    seed: int = typer.Option(0, "--seed", help="The map: the one evaluation draws for this seed."),
    json_path: Path | None = typer.Option(None, "--json", help="Write start, goal, path, obstacles, time, validity."),
    png: Path | None = typer.Option(None, "--png", help="Draw the map and the path."),
    maps: int = typer.Option(1, "--maps", help="Plan this many maps (seeds SEED..) and print timing figures."),
) -> None:
    """Plan the object's path through a random long-horizon map with OMPL (level=high's planner settings)."""
    import json

    from mapush.commands import plan as planning
    from mapush.config import compose_config, to_plain
    from mapush.levels import make_planner

    if maps < 1:
        raise BadInput(f"--maps {maps} must be 1 or more")
    for path, flag in ((json_path, "--json"), (png, "--png")):
        if path is not None:
            output_file(path, flag)
    cfg = to_plain(compose_config(["level=high", f"task={task}", f"seed={seed}", *ctx.args]))
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


@app.command(context_settings=PASS_THROUGH)
def calibrate(
    ctx: typer.Context,
    steps: str = typer.Option("0.25,0.5", "--steps", help="Step command sizes (m/s, rad/s), comma-separated."),
    settle: float = typer.Option(1.0, "--settle", help="Seconds of standing before each step."),
    duration: float = typer.Option(3.0, "--duration", help="Seconds each step command is held."),
    repeats: int = typer.Option(6, "--repeats", help="Starts per drag and per held load."),
    seed: int = typer.Option(0, "--seed", help="Draws the starts of the capacity and fall sweeps."),
    out: Path | None = typer.Option(None, "--out", help="Output dir (default runs/calibrate/<time>)."),
    config: Path | None = typer.Option(
        None,
        "--config",
        help="A tracker config to update in place (e.g. mapush/conf/lowlevel/tracker.yaml of a checkout); default: "
        "OUT/tracker.yaml, the package's with the measured values.",
    ),
) -> None:
    """Measure a legged low level (its lags, push capacity and falls under load) and write the tracker's values.

    Overrides choose the robot measured: `lowlevel.policy=RUN/policy.pt` (default: lowlevel=go1, shipped policy).
    """
    import datetime

    from mapush.atomic import write_text
    from mapush.calibration.run import calibrate as run_calibration
    from mapush.calibration.run import default_config_path

    step_sizes = number_list(steps, "--steps", kind=float, minimum=1e-3)
    if settle < 0 or duration <= 0:
        raise BadInput(f"--settle {settle} / --duration {duration}: valid: settle >= 0, duration > 0 seconds")
    if repeats < 1:
        raise BadInput(f"--repeats {repeats}: valid: 1 or more")
    overrides = list(ctx.args)
    reference = overrides if any(o.startswith("lowlevel=") for o in overrides) else ["lowlevel=go1", *overrides]
    stamp = datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    out_dir = output_dir(out or Path("runs") / "calibrate" / stamp, "--out")
    if config is not None and not config.is_file():
        raise BadInput(f"--config {config}: no such file; valid: a tracker config (e.g. {default_config_path()})")
    if config is None:  # the package's own config stays as it is: the measured copy goes beside the record
        out_dir.mkdir(parents=True, exist_ok=True)
        config_path = out_dir / "tracker.yaml"
        write_text(config_path, default_config_path().read_text())
    else:
        config_path = config
    summary = run_calibration(reference, step_sizes, settle, duration, out_dir, config_path, repeats, seed)
    written = ", ".join(
        f"{k} {v:.4g}" if not isinstance(v, dict) else f"{k} {v}" for k, v in summary["written"].items()
    )
    print(f"capacity {summary['capacity_n']} N, fall curve {summary['fall_curve']}")
    print(f"wrote {written} -> {config_path}")
    for warning in summary["warnings"]:
        print(f"warning: {warning}")
    print(out_dir)


@app.command()
def plot(
    run_dirs: list[Path] = typer.Argument(..., help="Run dirs; runs differing only in seed become mean +- std."),
    out: Path | None = typer.Option(
        None, "-o", "--out", help="PNG (default: RUN_DIR/curves.png, or ./curves.png for several runs)."
    ),
    smooth: int = typer.Option(5, "--smooth", help="Moving-average window in logged points (1 = raw)."),
) -> None:
    """Draw learning curves (success rate, reward terms) from metrics.mcap as a PNG."""
    from mapush.commands.plot import plot_runs

    if out is None:
        out = run_dirs[0] / "curves.png" if len(run_dirs) == 1 else Path("curves.png")
    print(plot_runs(run_dirs, output_file(out, "-o"), smooth))


@app.command(name="list")
def list_choices() -> None:
    """List what a config can choose (config groups and their options), the trusted code and the shipped policies."""
    from mapush.config import GROUPS, group_options
    from mapush.rundir import shipped_names
    from mapush.trust import trusted_modules

    for group in (*GROUPS, "method", "experiment", "launcher"):  # the last three: `mapush sweep`'s groups
        print(f"{group + ':':<12}{', '.join(group_options(group))}")
    print(
        f"{'shipped:':<12}{', '.join(shipped_names())}   (mapush eval shipped:NAME, mapush.load_policy('shipped:NAME'))"
    )
    print(f"{'trusted:':<12}{', '.join(trusted_modules())}   (more with mapush --trust MODULE)")
