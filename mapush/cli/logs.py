"""`mapush logs`: inspect and repair MCAP logs."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app
from mapush.errors import BadInput

logs = typer.Typer(no_args_is_help=True, help="Inspect and repair MCAP logs (metrics.mcap, episodes.mcap).")
app.add_typer(logs, name="logs")


@logs.command()
def summary(file: Path = typer.Argument(..., help="An .mcap file, finished or cut.")) -> None:
    """Print the topics (schema, message count), the time span and whether the file is complete."""
    from datetime import UTC, datetime

    from mapush.logging.mcap_files import summary as read_summary

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


@logs.command()
def recover(
    file: Path = typer.Argument(..., help="A cut .mcap file (e.g. from a killed run)."),
    out: Path = typer.Option(..., "-o", "--out", help="Where to write the readable, indexed copy."),
) -> None:
    """Copy every complete record of a cut MCAP file into a readable, indexed file."""
    from mapush.logging.mcap_files import recover as recover_file

    if out.resolve() == file.resolve():
        raise BadInput(f"-o {str(out)!r} is the input file; valid: another path (the original is kept)")
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
