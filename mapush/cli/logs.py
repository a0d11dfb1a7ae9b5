"""`mapush logs`: inspect and repair MCAP logs."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app, output_file
from mapush.errors import BadInput

logs = typer.Typer(no_args_is_help=True, help="Inspect and repair MCAP logs (metrics.mcap, episodes.mcap).")
app.add_typer(logs, name="logs")


@logs.command()
def summary(
    path: Path = typer.Argument(..., help="An .mcap file (finished or cut), or a run dir (all its metrics parts)."),
) -> None:
    """Print a file's topics (schema, message count), time span and whether it is complete, and each training
    scalar's last, lowest and highest value; for a run dir, its metrics files read as one series."""
    from mapush.logging.mcap_files import metrics_parts, training_scalars
    from mapush.logging.scalars import format_summary, summarize

    if path.is_dir():
        parts = metrics_parts(path)
        print(f"{path}: {len(parts)} metrics file(s) read as one run: {', '.join(p.name for p in parts) or 'none'}")
        print(format_summary(summarize(training_scalars(path))))
        return
    _print_file_summary(path)


def _print_file_summary(file: Path) -> None:
    from datetime import UTC, datetime

    from mapush.logging.mcap_files import file_scalars
    from mapush.logging.mcap_files import summary as read_summary
    from mapush.logging.scalars import format_summary, summarize

    info = read_summary(file)
    state = "complete" if info["complete"] else "CUT (no index: run `mapush logs recover` for an indexed copy)"
    print(f"{info['file']}: {state}")
    if info["messages"]:
        start = datetime.fromtimestamp(info["start_ns"] / 1e9, tz=UTC).isoformat(timespec="milliseconds")
        print(f"{info['messages']} messages over {info['duration_s']:.3f} s from {start}")
    else:
        print("0 messages")
    width = max((len(t) for t in info["topics"]), default=5)
    for topic, row in info["topics"].items():
        print(f"  {topic:<{width}}  {row['messages']:>8}  {row['schema']}")
    for kind in ("metadata", "attachments"):
        if info[kind]:
            print(f"{kind}: {', '.join(info[kind])}")
    scalars = file_scalars(file)
    if scalars:
        print(format_summary(summarize(scalars)))


@logs.command()
def export(
    run: Path = typer.Argument(..., help="A run dir made by `mapush train` (resumed parts included)."),
    csv: bool = typer.Option(
        True, "--csv/--json", help="CSV: a row per iteration, a column per scalar; JSON: {scalar: {iteration: value}}."
    ),
    out: Path | None = typer.Option(None, "-o", "--out", help="Write here (a new file) instead of printing."),
) -> None:
    """Every training scalar of a run, all its metrics files as one series, as CSV (or JSON)."""
    import json

    from mapush.atomic import write_text
    from mapush.logging.mcap_files import training_scalars
    from mapush.logging.scalars import to_csv

    if not run.is_dir():
        raise BadInput(f"{str(run)!r} is not a run dir; valid: a dir made by `mapush train` with metrics.mcap")
    if out is not None and (out.exists() or out.is_symlink()):
        raise BadInput(f"-o {str(out)!r} exists; valid: a new file path (nothing is overwritten)")
    scalars = training_scalars(run)
    text = to_csv(scalars) if csv else json.dumps(scalars, indent=1) + "\n"
    if out is None:
        print(text, end="")
    else:
        write_text(out, text)
        print(out)


@logs.command()
def recover(
    file: Path = typer.Argument(..., help="A cut .mcap file (e.g. from a killed run)."),
    out: Path = typer.Option(..., "-o", "--out", help="Where to write the readable, indexed copy."),
) -> None:
    """Copy every complete record of a cut MCAP file into a readable, indexed file."""
    from mapush.logging.mcap_files import recover as recover_file

    if out.resolve() == file.resolve():
        raise BadInput(f"-o {str(out)!r} is the input file; valid: another path (the original is kept)")
    output_file(out, "-o")
    result = recover_file(file, out)
    cut = "" if result["complete_source"] else " (the source was cut)"
    print(f"recovered {result['messages']} messages{cut} into {result['file']}")


@logs.command(context_settings=PASS_THROUGH)
def layout(
    ctx: typer.Context,
    out: Path | None = typer.Option(None, "-o", "--out", help="Write here instead of printing."),
) -> None:
    """The Foxglove layout (3D scene, command and reward plots, episode log) for a config's episode files."""
    from mapush.config import compose_config, to_plain
    from mapush.logging.layout import episode_layout
    from mapush.rewards.manager import RewardManager

    if out is not None:
        output_file(out, "-o")
    cfg = to_plain(compose_config(list(ctx.args)))
    text = episode_layout(list(RewardManager(cfg["reward"]["terms"]).terms)).to_json()
    if out is None:
        print(text)
    else:
        out.write_text(text + "\n")
        print(out)


@logs.command()
def episodes(
    file: Path = typer.Argument(..., help="An episodes.mcap (eval) or train_episodes.mcap of a pushing level."),
    as_json: bool = typer.Option(False, "--json", help="Print the rows as JSON instead of a Markdown table."),
) -> None:
    """How the object moved in each recorded episode: travel against the reference path, stalls, obstacle contact."""
    import json

    from mapush.logging.episode_stats import episode_stats, format_rows, read_tracks

    rows = [episode_stats(track) for track in read_tracks(file)]
    if not rows:
        raise BadInput(f"{str(file)!r} holds no finished episode; valid: an episodes.mcap with at least one")
    print(json.dumps(rows, indent=1) if as_json else format_rows(rows))
