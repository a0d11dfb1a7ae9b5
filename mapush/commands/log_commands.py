"""What `mapush logs` does (`mapush.cli.logs` reads its arguments): summary, export, recover, layout, episodes."""

from __future__ import annotations

from pathlib import Path

from mapush.commands.arguments import output_file
from mapush.errors import BadInput


def summary(path: Path) -> None:
    """`mapush logs summary`: a file's topics, span and completeness and its scalars; for a run dir, its metrics
    files read as one series."""
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


def export(run: Path, csv: bool, out: Path | None) -> None:
    """`mapush logs export`: every training scalar of `run` as CSV (or JSON), printed or written to `out`."""
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


def recover(file: Path, out: Path) -> None:
    """`mapush logs recover`: every complete record of a cut MCAP file copied into a readable, indexed `out`."""
    from mapush.logging.mcap_files import recover as recover_file

    if out.resolve() == file.resolve():
        raise BadInput(f"-o {str(out)!r} is the input file; valid: another path (the original is kept)")
    output_file(out, "-o")
    result = recover_file(file, out)
    cut = "" if result["complete_source"] else " (the source was cut)"
    print(f"recovered {result['messages']} messages{cut} into {result['file']}")


def layout(overrides: list[str], out: Path | None) -> None:
    """`mapush logs layout`: the Foxglove layout for the episode files of the config of `overrides`."""
    if out is not None:
        output_file(out, "-o")
    from mapush.config import compose_config, to_plain  # after the check: the reward terms import the envs
    from mapush.logging.layout import episode_layout
    from mapush.rewards.manager import RewardManager

    cfg = to_plain(compose_config(overrides))
    text = episode_layout(list(RewardManager(cfg["reward"]["terms"]).terms)).to_json()
    if out is None:
        print(text)
    else:
        out.write_text(text + "\n")
        print(out)


def episodes(file: Path, as_json: bool) -> None:
    """`mapush logs episodes`: how the object moved in each recorded episode, as a Markdown table or JSON."""
    import json

    from mapush.logging.episode_stats import episode_stats, format_rows, read_tracks

    rows = [episode_stats(track) for track in read_tracks(file)]
    if not rows:
        raise BadInput(f"{str(file)!r} holds no finished episode; valid: an episodes.mcap with at least one")
    print(json.dumps(rows, indent=1) if as_json else format_rows(rows))
