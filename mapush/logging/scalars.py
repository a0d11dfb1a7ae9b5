"""A run's training scalars as a table: one row per iteration for CSV, each tag's last, lowest and highest value.

The scalars come from `mcap_files.training_scalars`, which reads `metrics.mcap` and the parts a resume added
(`metrics.1.mcap`, ...) as one series, so an export or a summary of a resumed run is the whole run's.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

ITERATION_COLUMN = "iteration"
"""The CSV's first column: the iteration as the metrics and checkpoints number it (`model_<iteration>.pt`)."""


@dataclass(frozen=True)
class ScalarSummary:
    """One tag over a run: how many iterations logged it, the last one's value, its lowest and highest values."""

    tag: str
    count: int
    last_iteration: int
    last: float
    lowest: float
    highest: float


def summarize(scalars: dict[str, dict[int, float]]) -> list[ScalarSummary]:
    """Each tag's summary, tags in alphabetical order; NaN values (none logged that iteration) are left out of
    the lowest and highest."""
    rows = []
    for tag in sorted(scalars):
        series = scalars[tag]
        if not series:
            continue
        last_iteration = max(series)
        finite = [v for v in series.values() if not math.isnan(v)] or [math.nan]
        rows.append(ScalarSummary(tag, len(series), last_iteration, series[last_iteration], min(finite), max(finite)))
    return rows


def format_summary(rows: list[ScalarSummary]) -> str:
    """The summaries as aligned text lines: tag, iterations logged, last (at iteration), lowest, highest."""
    if not rows:
        return "no training scalars"
    width = max(len(r.tag) for r in rows)
    head = f"  {'scalar':<{width}}  {'iters':>6}  {'last':>12} {'(at)':>7}  {'lowest':>12}  {'highest':>12}"
    lines = [head]
    for r in rows:
        lines.append(
            f"  {r.tag:<{width}}  {r.count:>6}  {r.last:>12.6g} {f'({r.last_iteration})':>7}  "
            f"{r.lowest:>12.6g}  {r.highest:>12.6g}"
        )
    return "\n".join(lines)


def to_csv(scalars: dict[str, dict[int, float]]) -> str:
    """Every scalar, one row per iteration that logged any, one column per tag (alphabetical), empty where the
    iteration did not log the tag."""
    tags = sorted(scalars)
    iterations = sorted({it for series in scalars.values() for it in series})
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([ITERATION_COLUMN, *tags])
    for it in iterations:
        writer.writerow([it, *(repr(scalars[t][it]) if it in scalars[t] else "" for t in tags)])
    return out.getvalue()
