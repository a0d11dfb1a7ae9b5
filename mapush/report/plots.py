"""The tables' plots: learning curves (`curves_plot`), the scalability study's robot counts (`scale_plot`) and the
team study's heatmaps (`team_plot`); what the curves say is read in `curve_findings.py`."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from mapush.experiments.results import JobResult
from mapush.report.curve_findings import curve_made_otherwise, mean_curve, seed_curves
from mapush.report.formats import ALONE, ALONE_LEGEND, OTHERWISE, OTHERWISE_LEGEND, Table, counted


def _pyplot():
    """matplotlib's pyplot on the Agg backend: files only, no display."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def curves_plot(
    panels: dict[str, dict[str, list[JobResult]]], path: Path, title: str, stage: str | None = None
) -> bool:
    """Evaluated success against env-steps, mean +- std over seeds: one panel per key of `panels`, one line per
    label (`{panel: {label: results}}`), of the evaluated stages' curves or of `stage`'s own. Returns False (and
    draws nothing) when no result has such a curve."""
    drawn = {p: {k: seed_curves(v, stage) for k, v in lines.items()} for p, lines in panels.items()}
    drawn = {p: {k: v for k, v in lines.items() if v} for p, lines in drawn.items()}
    drawn = {p: lines for p, lines in drawn.items() if lines}
    if not drawn:
        return False
    otherwise = {
        (p, k) for p, lines in drawn.items() for k in lines if any(curve_made_otherwise(r, stage) for r in panels[p][k])
    }
    plt = _pyplot()

    labels = list(dict.fromkeys(label for lines in drawn.values() for label in lines))
    color = {label: f"C{k % 10}" for k, label in enumerate(labels)}  # one colour per label in every panel
    rows = -(-max(len(lines) for lines in drawn.values()) // 2)  # legend rows under each panel, 2 entries per row
    title = textwrap.fill(title, 48 * len(drawn))  # about 48 characters of the title fit above a 4.6-inch panel
    title += f"\n{OTHERWISE_LEGEND}" if otherwise else ""
    height = 3.4 + 0.22 * rows + 0.25 * title.count("\n")
    fig, axes = plt.subplots(1, len(drawn), figsize=(4.6 * len(drawn), height), squeeze=False, sharey=True)
    for ax, (panel, lines) in zip(axes[0], drawn.items(), strict=True):
        for label, per_seed in lines.items():
            x, mean, std = mean_curve(per_seed)
            line_label = f"{label} ({counted(len(per_seed), 'seed')})" + (
                f" {OTHERWISE}" if (panel, label) in otherwise else ""
            )
            ax.plot(x / 1e6, 100 * mean, marker="o", ms=3, color=color[label], label=line_label)
            ax.fill_between(x / 1e6, 100 * (mean - std), 100 * (mean + std), color=color[label], alpha=0.2)
        ax.set_title(panel)
        ax.set_xlabel("env-steps (M)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.2), frameon=False)  # off the curves
    axes[0][0].set_ylabel("evaluated success (%)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def scale_plot(table: Table, path: Path) -> None:
    """S.R. (the hierarchy's and the mid level's), the hierarchy's falls and its C.T. against the number of robots,
    with std error bars."""
    plt = _pyplot()

    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    counts = [int(labels[0]) for labels, _ in table.rows]
    series = (
        (axes[0], 0, "hierarchy"),
        (axes[0], 2, "mid level"),
        (axes[0], 3, "falls (hierarchy)"),
        (axes[1], 1, "hierarchy"),
    )
    for ax, k, name in series:
        pts = [
            (n, cells[k].mean, cells[k].std)
            for n, (_, cells) in zip(counts, table.rows, strict=True)
            if len(cells) > k and cells[k].values
        ]
        if pts:
            n, m, s = zip(*pts, strict=True)
            ax.errorbar(n, m, yerr=s, marker="o", capsize=3, label=name)
    for ax, label in ((axes[0], "S.R., falls (% of episodes)"), (axes[1], "C.T. (normalized)")):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        ax.set_xlabel("robots")
        ax.set_ylabel(label)
        ax.set_xticks(counts)
        ax.grid(alpha=0.3)
    fig.suptitle(table.title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def team_plot(table: Table, path: Path) -> None:
    """One heatmap per object: robots (rows) x mass (columns), coloured by S.R., each cell labelled with its S.R.
    and capacity margin (and its mark where it came from a policy trained at that mass alone)."""
    plt = _pyplot()

    tasks = list(dict.fromkeys(labels[0] for labels, _ in table.rows))
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.2 * len(tasks), 3.6), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        rows = [(int(labels[1]), cells) for labels, cells in table.rows if labels[0] == task]
        grid = np.array([[np.nan if c.mean is None else c.mean for c in cells] for _, cells in rows])
        image = ax.imshow(grid, vmin=0, vmax=100, cmap="viridis", origin="lower", aspect="auto")
        for i, (_, cells) in enumerate(rows):
            for j, cell in enumerate(cells):
                value = "n/a" if cell.mean is None else f"{cell.mean:.0f} %"
                value += f" {cell.mark}" if cell.mark else ""  # the mark by the value: the margin fills its line
                ax.text(j, i, f"{value}\n{cell.note}", ha="center", va="center", fontsize=7, color="w")
        ax.set_xticks(range(len(table.columns)), table.columns)
        ax.set_yticks(range(len(rows)), [str(n) for n, _ in rows])
        ax.set_xlabel("object mass")
        ax.set_ylabel("robots")
        ax.set_title(task)
        fig.colorbar(image, ax=ax, label="S.R. (%)")
    alone = any(cell.mark == ALONE for _, cells in table.rows for cell in cells)
    fig.suptitle(table.title + (f"\n{ALONE_LEGEND}" if alone else ""), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def ladder_plot(table: Table, path: Path) -> None:
    """S.R. against the ladder's rungs, one line per row with std error bars, a panel per group of rows that its
    declaration names (`panels`: Ours and SA by object, the cylinder's robot counts, OCB's mid levels)."""
    plt = _pyplot()

    cells_of = {tuple(labels): cells for labels, cells in table.rows}
    panels = table.panels or {"": [labels for labels, _ in table.rows]}  # no panels declared: one of every row
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 3.8), sharey=True, squeeze=False)
    rungs = range(len(table.columns))
    for ax, (panel, members) in zip(axes[0], panels.items(), strict=True):
        for labels in members:
            pts = [(k, c.mean, c.std) for k, c in zip(rungs, cells_of[tuple(labels)], strict=True) if c.values]
            if pts:
                k, m, s = zip(*pts, strict=True)
                ax.errorbar(k, m, yerr=s, marker="o", capsize=3, label=" / ".join(labels))
        ax.set_xticks(list(rungs), table.columns, rotation=30, ha="right", fontsize=8)
        ax.set_title(panel)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    axes[0][0].set_ylabel("S.R. (%)")
    fig.suptitle(textwrap.fill(table.title, 110), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
