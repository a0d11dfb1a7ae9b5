"""`mapush probe`: what a trained level does inside its evaluation's episodes (commands, falls, progress), how
long the paths are that the high level is evaluated on (paths), how often a low level's robot falls under
reversing commands (reversals) or squeezed by its teammates (squeeze), and which of its parts push the object
(contacts). What each does: `mapush.commands.probe_commands`."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app
from mapush.commands import probe_commands

probe_app = typer.Typer(
    help="Look inside a trained level's evaluation: its commands, where its robots fall, where its pushes go; and "
    "the lengths of the evaluation's paths.",
    no_args_is_help=True,
)
app.add_typer(probe_app, name="probe")

TARGET = "A run dir (its latest checkpoint) or a model_<it>.pt file."


@probe_app.command(context_settings=PASS_THROUGH)
def commands(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help=f"A mid level: {TARGET}"),
    episodes: int = typer.Option(64, "--episodes", help="Pushes, one per env (seed 0)."),
) -> None:
    """How hard a mid level drives its robots: its velocity commands (shares of level.action_scale) per axis, over
    each env's first push, as trained or with overrides (e.g. lowlevel=go1): mean magnitude, share saturated
    (>= 0.95), mean change per step."""
    probe_commands.commands(target, episodes, list(ctx.args))


@probe_app.command(context_settings=PASS_THROUGH)
def falls(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help=f"A high level: {TARGET}"),
    episodes: int = typer.Option(50, "--episodes", help="Episodes, one per env (seed 0)."),
    go_on: bool = typer.Option(False, "--go-on", help="A fall does not end the episode: see who gets up again."),
    replay: int = typer.Option(
        0, "--replay", help="Replay the seconds of commands before each fall on this many free robots (0: none)."
    ),
) -> None:
    """Where a hierarchy's Go1s fall (lowlevel=go1, then the overrides): the evaluation's exception shares, and at
    each env's first fall the quartiles of the fallen robot's distances to the object, its nearest teammate and the
    nearest obstacle, how often its command was at full scale, and how it moved in the second before it tumbled,
    beside every robot-step. With --go-on, how many fallen robots got up; with --replay, whether the commands alone
    topple the same robot walking free (the object parked away)."""
    probe_commands.falls(target, episodes, list(ctx.args), go_on, replay)


@probe_app.command()
def progress(
    target: Path = typer.Argument(..., help=f"A mid level: {TARGET}"),
    episodes: int = typer.Option(50, "--episodes", help="Pushes, one per env (seed 0)."),
    compare: list[str] = typer.Option(
        [],
        "--compare",
        help="An override (e.g. lowlevel=go1) to evaluate with besides as trained; repeat it for several, "
        "all applied together.",
    ),
) -> None:
    """Where a mid level's pushes take the object, and on which side of it the robots stand: for successes and
    failures apart, the distance to the subgoal at the start and the end, the share that ended farther than it
    started, and the share of robot-steps ahead of the object."""
    probe_commands.progress(target, episodes, compare)


@probe_app.command(context_settings=PASS_THROUGH)
def paths(
    ctx: typer.Context,
    tasks: str = typer.Option("cuboid,tblock,cylinder", "--tasks", help="Comma-separated objects (conf/task/)."),
    episodes: int = typer.Option(50, "--episodes", help="Maps, one per env."),
    seed: int = typer.Option(0, "--seed", help="The evaluation seed that draws the maps."),
) -> None:
    """How far the hierarchy has to push: the lengths of the paths the high level is evaluated on, per object (the
    maps `mapush eval` draws, planned as level.planner.* says; overrides such as level.planner.name=RRTstar follow,
    after `--` or not)."""
    probe_commands.paths(tasks, episodes, seed, list(ctx.args))


@probe_app.command(context_settings=PASS_THROUGH)
def reversals(
    ctx: typer.Context,
    envs: int = typer.Option(64, "--envs", help="Robots per reversal rate."),
    seconds: float = typer.Option(20.0, "--seconds", help="How long each robot walks."),
    seed: int = typer.Option(0, "--seed", help="Draws the signs and the reversals."),
) -> None:
    """How often a low level's robot falls walking free under full-scale commands (the mid level's action_scale on
    every axis) whose signs reverse at random, at 0 to 15 reversals per second per axis (overrides choose the robot;
    default lowlevel=go1)."""
    probe_commands.reversals(list(ctx.args), envs, seconds, seed)


@probe_app.command(context_settings=PASS_THROUGH)
def squeeze(
    ctx: typer.Context,
    envs: int = typer.Option(24, "--envs", help="Starts per layout."),
    seed: int = typer.Option(0, "--seed", help="Draws the starts (a lateral offset and a heading error each)."),
) -> None:
    """How often a low level's robot falls squeezed between the object and its teammates' pushes: alone against an
    immovable cuboid, from a run-up, with one or two teammates in a line behind it, with a teammate across the object,
    and shoved back by two across it, also graded by their speed (overrides choose the robot; default lowlevel=go1)."""
    probe_commands.squeeze(list(ctx.args), envs, seed)


@probe_app.command(context_settings=PASS_THROUGH)
def contacts(
    ctx: typer.Context,
    speeds: str = typer.Option("0.3,0.5", "--speeds", help="Comma-separated command speeds, m/s."),
    envs: int = typer.Option(16, "--envs", help="Starts per speed."),
    seed: int = typer.Option(0, "--seed", help="Draws the starts (a lateral offset and a heading error each)."),
) -> None:
    """How a low level's robot pushes an object alone: which of its parts touch it, how hard (read at every physics
    step), and how fast the object goes against the command (overrides choose the robot, default lowlevel=go1, and
    the object, default task=cuboid)."""
    probe_commands.contacts(list(ctx.args), speeds, envs, seed)
