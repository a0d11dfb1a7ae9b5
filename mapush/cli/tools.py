"""Measuring and inspecting commands: bench, plan, calibrate, plot, list (what they do:
`mapush.commands.tool_commands`)."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app
from mapush.commands import tool_commands


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
    tool_commands.bench(list(ctx.args), json_path, learn, minutes, video, out)


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
    tool_commands.plan(list(ctx.args), task, seed, json_path, png, maps)


@app.command(context_settings=PASS_THROUGH)
def calibrate(
    ctx: typer.Context,
    steps: str = typer.Option("0.25,0.5", "--steps", help="Step command sizes (m/s, rad/s), comma-separated."),
    settle: float = typer.Option(1.0, "--settle", help="Seconds of standing before each step."),
    duration: float = typer.Option(3.0, "--duration", help="Seconds each step command is held."),
    repeats: int = typer.Option(6, "--repeats", help="Starts per drag and per held load."),
    seed: int = typer.Option(0, "--seed", help="Draws the starts of the capacity and fall sweeps."),
    out: Path | None = typer.Option(None, "--out", help="Output dir (default runs/calibrate/<time>)."),
    name: str = typer.Option(
        "tracker_calibrated", "--name", help="The tracker's option: OUT/lowlevel/NAME.yaml, used as lowlevel=NAME."
    ),
    config: Path | None = typer.Option(None, "--config", hidden=True),  # gone: it rewrote a config in place
) -> None:
    """Measure a legged low level (its lags, push capacity and falls under load) and write a tracker that stands
    for it: OUT/lowlevel/NAME.yaml, the package's tracker with the measured values (the package is never written).

    Overrides choose the robot measured: `lowlevel.policy=RUN/policy.pt` (default: lowlevel=go1, shipped policy).
    The last lines say how to use it: mapush train lowlevel=NAME 'hydra.searchpath=[file://OUT]'.
    """
    tool_commands.calibrate(list(ctx.args), steps, settle, duration, repeats, seed, out, name, config)


@app.command()
def plot(
    run_dirs: list[Path] = typer.Argument(..., help="Run dirs; runs differing only in seed become mean +- std."),
    out: Path | None = typer.Option(
        None, "-o", "--out", help="PNG (default: RUN_DIR/curves.png, or ./curves.png for several runs)."
    ),
    smooth: int = typer.Option(5, "--smooth", help="Moving-average window in logged points (1 = raw)."),
) -> None:
    """Draw learning curves (success rate, reward terms) from metrics.mcap as a PNG."""
    tool_commands.plot(run_dirs, out, smooth)


@app.command(name="list")
def list_choices() -> None:
    """List what a config can choose (config groups and their options), the trusted code and the shipped policies."""
    tool_commands.list_choices()
