"""`mapush logs`: inspect and repair MCAP logs (what it does: `mapush.commands.log_commands`)."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app
from mapush.commands import log_commands

logs = typer.Typer(no_args_is_help=True, help="Inspect and repair MCAP logs (metrics.mcap, episodes.mcap).")
app.add_typer(logs, name="logs")


@logs.command()
def summary(
    path: Path = typer.Argument(..., help="An .mcap file (finished or cut), or a run dir (all its metrics parts)."),
) -> None:
    """Print a file's topics (schema, message count), time span and whether it is complete, and each training
    scalar's last, lowest and highest value; for a run dir, its metrics files read as one series."""
    log_commands.summary(path)


@logs.command()
def export(
    run: Path = typer.Argument(..., help="A run dir made by `mapush train` (resumed parts included)."),
    csv: bool = typer.Option(
        True, "--csv/--json", help="CSV: a row per iteration, a column per scalar; JSON: {scalar: {iteration: value}}."
    ),
    out: Path | None = typer.Option(None, "-o", "--out", help="Write here (a new file) instead of printing."),
) -> None:
    """Every training scalar of a run, all its metrics files as one series, as CSV (or JSON)."""
    log_commands.export(run, csv, out)


@logs.command()
def recover(
    file: Path = typer.Argument(..., help="A cut .mcap file (e.g. from a killed run)."),
    out: Path = typer.Option(..., "-o", "--out", help="Where to write the readable, indexed copy."),
) -> None:
    """Copy every complete record of a cut MCAP file into a readable, indexed file."""
    log_commands.recover(file, out)


@logs.command(context_settings=PASS_THROUGH)
def layout(
    ctx: typer.Context,
    out: Path | None = typer.Option(None, "-o", "--out", help="Write here instead of printing."),
) -> None:
    """The Foxglove layout (3D scene, command and reward plots, episode log) for a config's episode files."""
    log_commands.layout(list(ctx.args), out)


@logs.command()
def episodes(
    file: Path = typer.Argument(..., help="An episodes.mcap (eval) or train_episodes.mcap of a pushing level."),
    as_json: bool = typer.Option(False, "--json", help="Print the rows as JSON instead of a Markdown table."),
) -> None:
    """How the object moved in each recorded episode: travel against the reference path, stalls, obstacle contact."""
    log_commands.episodes(file, as_json)
