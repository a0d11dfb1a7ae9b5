"""`mapush tables`: the paper's tables as Markdown, LaTeX (booktabs) and CSV, built from sweep jobs' results.

Every cell is the mean +- std over training seeds of the jobs' `result.json` evaluations; its sidecar
`<table>.json` names the job dirs behind it. A cell with no finished job is marked with an em dash and listed
with the reason. The paper's numbers (`paper.yaml`) stand beside ours where the paper has them.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from mapush.experiments.pipeline import RESULT

PAPER = yaml.safe_load((Path(__file__).with_name("paper.yaml")).read_text())
MISSING = "\u2014"


@dataclass
class Cell:
    """One table cell: per-seed values and the job dirs they came from; `paper` is (mean, std) or None."""

    values: list[float] = field(default_factory=list)
    sources: list[str] = field(default_factory=list)
    paper: tuple[float, float] | None = None
    digits: int = 1

    def text(self) -> str:
        digits = self.digits
        ours = MISSING
        if len(self.values) == 1:  # no spread to show: say it is one seed rather than print a std of 0
            ours = f"{self.values[0]:.{digits}f} (1 seed)"
        elif self.values:
            ours = f"{np.mean(self.values):.{digits}f} \u00b1 {np.std(self.values):.{digits}f}"
        if self.paper is None:
            return ours
        return f"{ours} ({self.paper[0]:.{digits}f} \u00b1 {self.paper[1]:.{digits}f})"

    def record(self) -> dict:
        return {
            "mean": float(np.mean(self.values)) if self.values else None,
            "std": float(np.std(self.values)) if self.values else None,
            "seeds": len(self.values),
            "paper": list(self.paper) if self.paper else None,
            "sources": self.sources,
        }


@dataclass
class Table:
    """A grid of cells with row and column labels; `name` gives the file names."""

    name: str
    title: str
    row_header: list[str]
    columns: list[str]
    rows: list[tuple[list[str], list[Cell]]]  # (row labels, cells)
    missing: list[str] = field(default_factory=list)
    note: str = ""


def load_results(root: Path) -> list[dict]:
    """Every finished job's result under `root`, with its job dir."""
    results = []
    for path in sorted(Path(root).glob(f"**/{RESULT}")):
        result = json.loads(path.read_text())
        result["job_dir"] = str(path.parent)
        results.append(result)
    return results


def _collect(results: list[dict], metric: str, scale: float, **match) -> Cell:
    """The cell of the results that match (key: value or eval name), for one metric of one evaluation."""
    eval_name = match.pop("eval")
    cell = Cell()
    for r in results:
        if all(r.get(k) == v for k, v in match.items()) and eval_name in r["evals"]:
            cell.values.append(scale * r["evals"][eval_name][metric])
            cell.sources.append(r["job_dir"])
    return cell


def main_table(results: list[dict], variant: str) -> Table:
    """Table II's layout: rows task x metric, columns the methods in the paper's order."""
    paper = PAPER["main"]
    mine = [r for r in results if r["table"] == "main" and r["variant"] == variant]
    methods = paper["methods"]
    rows, missing = [], []
    for task in paper["tasks"]:
        for metric, key, scale, digits, label in (
            ("success_rate", "success_rate", 100.0, 1, "S.R. (%) \u2191"),
            ("completion_time", "completion_time", 1.0, 2, "C.T. \u2193"),
        ):
            cells = []
            for method in methods:
                cell = _collect(mine, key, scale, method=method, task=task, eval="main")
                cell.paper, cell.digits = tuple(paper[metric][task][method]), digits
                if not cell.values:
                    missing.append(f"{method} / {task} / {metric}: no finished job")
                cells.append(cell)
            rows.append(([paper["task_labels"][task], label], cells))
    return Table(
        f"main_{variant}",
        f"Main results ({variant}): ours (paper)",
        ["Task", "Metric"],
        [paper["labels"][m] for m in methods],
        rows,
        sorted(set(missing)),
        "S.R. over the evaluation trials, C.T. normalized by the timeout; mean \u00b1 std over training seeds.",
    )


def ocb_table(results: list[dict], variant: str) -> Table:
    """The OCB ablation: rows with and without OCB, columns S.R. and C.T. (s) at each timeout."""
    paper = PAPER["ocb_ablation"]
    mine = [r for r in results if r["table"] == "ocb_ablation" and r["variant"] == variant]
    columns, rows, missing = [], [], []
    for name in paper["evals"]:
        columns += [f"S.R. (%), {paper['eval_labels'][name]}", f"C.T. (s), {paper['eval_labels'][name]}"]
    for method in paper["methods"]:
        cells = []
        for name in paper["evals"]:
            for metric, key, scale in (
                ("success_rate", "success_rate", 100.0),
                ("completion_time_s", "completion_time_s", 1.0),
            ):
                cell = _collect(mine, key, scale, method=method, eval=name)
                cell.paper = tuple(paper[metric][name][method])
                if not cell.values:
                    missing.append(f"{method} / {name} / {metric}: no finished job")
                cells.append(cell)
        rows.append(([paper["labels"][method]], cells))
    return Table(
        f"ocb_ablation_{variant}",
        f"OCB ablation ({variant}): ours (paper)",
        ["Method"],
        columns,
        rows,
        missing,
        "Free space, 1.5 m cuboid of 6 kg, 2 robots, subgoals 1.5-3 m away; mean \u00b1 std over training seeds.",
    )


def scale_table(results: list[dict], variant: str) -> Table:
    """Scalability: rows the robot counts (the paper's and any run), columns S.R. and C.T. (the paper: a figure)."""
    mine = [r for r in results if r["table"] == "scale" and r["variant"] == variant]
    counts = sorted(set(PAPER["scale"]["robots"]) | {r["num_agents"] for r in mine})
    rows, missing = [], []
    for n in counts:
        cells = [
            _collect(mine, "success_rate", 100.0, num_agents=n, eval="main"),
            _collect(mine, "completion_time", 1.0, num_agents=n, eval="main"),
        ]
        cells[1].digits = 2
        if not cells[0].values:
            missing.append(f"{n} robots: no finished job")
        rows.append(([str(n)], cells))
    return Table(
        f"scale_{variant}",
        f"Scalability, cylinder ({variant})",
        ["Robots"],
        ["S.R. (%) \u2191", "C.T. \u2193"],
        rows,
        missing,
        "Whole hierarchy; C.T. normalized by the timeout; mean \u00b1 std over training seeds. "
        "The paper gives a figure only.",
    )


def markdown(table: Table) -> str:
    head = [*table.row_header, *table.columns]
    lines = [f"**{table.title}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for labels, cells in table.rows:
        lines.append("| " + " | ".join([*labels, *(c.text() for c in cells)]) + " |")
    lines += ["", table.note]
    if table.missing:
        lines += ["", f"Missing cells ({MISSING}):", *(f"- {m}" for m in table.missing)]
    return "\n".join(lines) + "\n"


def latex(table: Table) -> str:
    def esc(text: str) -> str:
        return (
            text.replace("\u00b1", "$\\pm$")
            .replace("%", "\\%")
            .replace("\u2191", "$\\uparrow$")
            .replace("\u2193", "$\\downarrow$")
            .replace(MISSING, "--")
            .replace("_", "\\_")
        )

    spec = "l" * len(table.row_header) + "c" * len(table.columns)
    lines = [
        "% generated by `mapush tables`; " + esc(table.note),
        "\\begin{tabular}{" + spec + "}",
        "\\toprule",
        " & ".join(esc(h) for h in [*table.row_header, *table.columns]) + " \\\\",
        "\\midrule",
    ]
    for labels, cells in table.rows:
        lines.append(" & ".join(esc(t) for t in [*labels, *(c.text() for c in cells)]) + " \\\\")
    lines += ["\\bottomrule", "\\end{tabular}"]
    return "\n".join(lines) + "\n"


def csv_text(table: Table) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["row", "column", "mean", "std", "seeds", "paper_mean", "paper_std", "sources"])
    for labels, cells in table.rows:
        for column, cell in zip(table.columns, cells, strict=True):
            rec = cell.record()
            paper = rec["paper"] or [None, None]
            writer.writerow(
                [" / ".join(labels), column, rec["mean"], rec["std"], rec["seeds"], *paper, ";".join(rec["sources"])]
            )
    return out.getvalue()


def sidecar(table: Table) -> dict:
    cells = [
        {"row": labels, "column": column, **cell.record()}
        for labels, cells in table.rows
        for column, cell in zip(table.columns, cells, strict=True)
    ]
    return {"table": table.name, "title": table.title, "cells": cells, "missing": table.missing}


def scale_plot(table: Table, path: Path) -> None:
    """S.R. and C.T. against the number of robots, with std error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    counts = [int(labels[0]) for labels, _ in table.rows]
    for ax, k, label in ((axes[0], 0, "S.R. (%)"), (axes[1], 1, "C.T. (normalized)")):
        pts = [
            (n, np.mean(cells[k].values), np.std(cells[k].values))
            for n, (_, cells) in zip(counts, table.rows, strict=True)
            if cells[k].values
        ]
        if pts:
            n, m, s = zip(*pts, strict=True)
            ax.errorbar(n, m, yerr=s, marker="o", capsize=3)
        ax.set_xlabel("robots")
        ax.set_ylabel(label)
        ax.set_xticks(counts)
        ax.grid(alpha=0.3)
    fig.suptitle(table.title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_tables(root: Path, out: Path) -> list[Table]:
    """Write every table of every sweep variant under `root` to `out`; the quick budget's even when empty.

    A variant is a budget plus any stage overrides of the sweep (`result.json`'s `variant`), so that a smoke or
    a modified sweep never mixes with the plain one.
    """
    results = load_results(root)
    variants = sorted({r["variant"] for r in results} | {"quick"})
    out.mkdir(parents=True, exist_ok=True)
    tables = []
    builders = {"main": main_table, "ocb_ablation": ocb_table, "scale": scale_table}
    for variant in variants:
        present = {r["table"] for r in results if r["variant"] == variant}
        for kind, build in builders.items():
            if variant != "quick" and kind not in present:
                continue
            table = build(results, variant)
            (out / f"{table.name}.md").write_text(markdown(table))
            (out / f"{table.name}.tex").write_text(latex(table))
            (out / f"{table.name}.csv").write_text(csv_text(table))
            (out / f"{table.name}.json").write_text(json.dumps(sidecar(table), indent=2) + "\n")
            if kind == "scale":
                scale_plot(table, out / f"{table.name}.png")
            tables.append(table)
    return tables
