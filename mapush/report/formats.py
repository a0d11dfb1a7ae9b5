"""A table as data (`Cell`, `Table`) and in each format `mapush tables` writes: Markdown, LaTeX (booktabs), CSV
and the JSON sidecar."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field

import numpy as np

from mapush.report.cost import cost_line

MISSING = "\u2014"
"""An empty cell: no finished job behind it."""
SIGNIFICANT = 6
"""Significant digits a cell keeps of each value: results hold float32 rates (a 42 % S.R. is 0.41999998688...),
so that a mean the table prints as 50.0 is 50.0 when a finding compares it."""
OVER_SEEDS = "mean \u00b1 std over training seeds (the population std: of two seeds, half their difference)"
"""What every cell's two numbers are, as the tables' notes say."""
OTHERWISE = "\u2020"
"""Marks a cell with seeds from jobs made otherwise than their experiment plans them now: an earlier recipe."""
MADE_OTHERWISE = "made otherwise than the experiment plans now (an earlier recipe)"
OTHERWISE_NOTE = f"{OTHERWISE} {MADE_OTHERWISE.capitalize()}, kept until trained again (`rerun_changed=true`):"
OTHERWISE_LEGEND = f"{OTHERWISE} {MADE_OTHERWISE}"
"""The same mark's note under a plot's title."""
NOT_APPLICABLE = "n/a"
"""A cell whose row does not stand in its column: its jobs make no such evaluation by design."""
ALONE = "\u2021"
"""Marks a team-study cell drawn from a policy trained at that cell's mass alone, not over the study's mass range."""
ALONE_LEGEND = f"{ALONE} trained at that mass alone"


@dataclass
class Cell:
    """One table cell: per-seed values and the job dirs they came from; `paper` is (mean, std) or None."""

    values: list[float] = field(default_factory=list)
    sources: list[str] = field(default_factory=list)
    paper: tuple[float, float] | None = None
    digits: int = 1
    unreached: int = 0  # seeds that never reached what the cell measures (e.g. env-steps to 50 % success)
    otherwise: int = 0  # seeds from jobs made otherwise than their experiment plans now (an earlier recipe)
    note: str = ""  # what the cell stands beside, in brackets after its value (e.g. the team study's margin)
    mark: str = ""  # a mark after the note (ALONE: drawn from policies trained at the cell's mass alone)
    applicable: bool = True  # False: its row does not stand in its column (a declared row's `evals`), "n/a"

    @property
    def bracket(self) -> str:
        """What the brackets after its value hold: the note, then the mark."""
        return self.note + (f" {self.mark}" if self.mark else "")

    def text(self) -> str:
        if not self.applicable:
            return NOT_APPLICABLE
        digits = self.digits
        ours = "never reached" if self.unreached else MISSING
        if self.unreached and self.values:
            ours = f"{self._ours()} ({self.unreached} of {self.unreached + len(self.values)} seeds never)"
        elif self.values:
            ours = self._ours()
        if self.otherwise:
            ours += f" {OTHERWISE}"
        if self.bracket:
            ours += f" [{self.bracket}]"
        if self.paper is None:
            return ours
        given = max(digits, *(_decimals(x) for x in self.paper))  # the paper's numbers as it gives them: 0.23, not 0.2
        return f"{ours} ({self.paper[0]:.{given}f} \u00b1 {self.paper[1]:.{given}f})"

    def _ours(self) -> str:
        digits = self.digits
        if len(self.values) == 1:  # no spread to show: say it is one seed rather than print a std of 0
            return f"{self.values[0]:.{digits}f} (1 seed)"
        return f"{self.mean:.{digits}f} \u00b1 {self.std:.{digits}f}"

    @property
    def mean(self) -> float | None:
        """The mean over seeds; None for an empty cell."""
        return float(np.mean(self.values)) if self.values else None

    @property
    def std(self) -> float | None:
        """The population std over seeds; None for an empty cell."""
        return float(np.std(self.values)) if self.values else None

    def record(self) -> dict:
        return {
            "mean": self.mean,
            "std": self.std,
            "seeds": len(self.values),
            "unreached": self.unreached,
            "made_otherwise": self.otherwise,
            "note": self.bracket if self.applicable else "not applicable",
            "paper": list(self.paper) if self.paper else None,
            "values": self.values,
            "sources": self.sources,
        }


def _decimals(number: float) -> int:
    """The decimals `number` is written with (0.23: 2, 24.3: 1, 4: 0)."""
    text = repr(float(number))
    return 0 if text.endswith(".0") else len(text.partition(".")[2])


@dataclass(frozen=True)
class Finding:
    """One thing a table says about its cells, as data: `text` (the statement with its numbers, as the Markdown
    lists it), whether it `holds` (True or False for a claim, the paper's or a budget rule's; None for a reading that
    claims nothing, or a comparison within the seeds' spread) and the `numbers` it rests on, by name (the sidecar
    JSON keeps all three). The main table compares means: its claims ignore the spread.

    `key` names what it judges or reads, the same in every table and run ("ours_vs_paper", "budget"), and
    `about` where (an object, a robot count, an evaluation, a curve's label): a reader or a test finds a finding
    by the two (`Table.finding`), never by its words.

    A declared table's claim (`declared.py`) says more: the `claim` it judges, its `op` (">", "<", ">=", "<=")
    and what each side of `numbers` is (`names`: "left", "right"; "" for a plain number); a side missing from
    `numbers` was not measured. The sidecar keeps them for such a finding only."""

    text: str
    holds: bool | None = None
    numbers: dict[str, float] = field(default_factory=dict)
    claim: str = ""
    op: str = ""
    names: dict[str, str] = field(default_factory=dict)
    key: str = ""
    about: str = ""

    def __str__(self) -> str:
        return self.text

    def record(self) -> dict:
        """The finding in the sidecar JSON."""
        declared = {"claim": self.claim, "op": self.op, "names": self.names} if self.claim else {}
        return {"key": self.key, "about": self.about, "text": self.text, "holds": self.holds,
                "numbers": self.numbers, **declared}  # fmt: skip


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
    findings: list[Finding] = field(default_factory=list)  # what holds here of the paper's findings, budget checks
    curves: dict = field(default_factory=dict)  # {panel: {label: results}} for the learning-curve plot
    cost: dict = field(default_factory=dict)  # what the runs behind it cost (`mapush.report.cost`)
    otherwise: list[str] = field(default_factory=list)  # jobs made otherwise than planned now, and how
    reading: str = ""  # how to read a cell, after the title in the table's heading: "ours (paper)"
    also_behind: list = field(default_factory=list)  # jobs of a variant with no table of its own that this one reads
    setup: str = ""  # the rules and low level its jobs were trained under, under the heading (`cells.setup_of`)
    panels: dict = field(default_factory=dict)  # {title: [row labels]}: how its own figure groups the rows

    @property
    def heading(self) -> str:
        return f"{self.title}: {self.reading}" if self.reading else self.title

    def finding(self, key: str, about: str = "") -> Finding:
        """The one finding of `key` about `about` (`pick`)."""
        return pick(self.findings, key, about)


def pick(findings: list[Finding], key: str, about: str = "") -> Finding:
    """The one finding of `key` about `about` among `findings`; a KeyError naming those there are when not one."""
    found = [f for f in findings if f.key == key and f.about == about]
    if len(found) != 1:
        raise KeyError(f"{len(found)} findings {key!r} about {about!r}; there are: {keys(findings)}")
    return found[0]


def keys(findings: list[Finding]) -> list[tuple[str, str]]:
    """Each finding's (key, about), in order."""
    return [(f.key, f.about) for f in findings]


def counted(n: int, noun: str) -> str:
    """`n` of `noun`, plural unless one: "1 robot", "2 robots", "3 seeds"."""
    return f"{n} {noun}" + ("s" if n != 1 else "")


def markdown(table: Table) -> str:
    head = [*table.row_header, *table.columns]
    lines = [f"**{table.heading}**", "", *([table.setup, ""] if table.setup else [])]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for labels, cells in table.rows:
        lines.append("| " + " | ".join([*labels, *(c.text() for c in cells)]) + " |")
    lines += ["", table.note]
    if table.findings:
        lines += ["", *(f"- {f}" for f in table.findings)]
    if cost_line(table.cost):
        lines += ["", cost_line(table.cost)]
    if table.missing:
        lines += ["", f"Missing cells ({MISSING}):", *(f"- {m}" for m in table.missing)]
    if table.otherwise:
        lines += ["", OTHERWISE_NOTE, *(f"- {m}" for m in table.otherwise)]
    return "\n".join(lines) + "\n"


def latex(table: Table) -> str:
    def esc(text: str) -> str:
        return (
            text.replace("\u00b1", "$\\pm$")
            .replace("%", "\\%")
            .replace("\u2191", "$\\uparrow$")
            .replace("\u2193", "$\\downarrow$")
            .replace(MISSING, "--")
            .replace(OTHERWISE, "$\\dagger$")
            .replace(ALONE, "$\\ddagger$")
            .replace("_", "\\_")
        )

    spec = "l" * len(table.row_header) + "c" * len(table.columns)
    lines = [
        "% generated by `mapush tables`; " + esc(table.note),
        *(["% " + esc(table.setup)] if table.setup else []),
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
    keys = ["mean", "std", "seeds", "unreached", "made_otherwise", "note"]  # every field of a cell but its lists
    writer.writerow(["row", "column", *keys, "paper_mean", "paper_std", "values", "sources"])
    for labels, cells in table.rows:
        for column, cell in zip(table.columns, cells, strict=True):
            rec = cell.record()
            numbers = [significant(rec[key]) for key in keys]
            paper = rec["paper"] or [None, None]
            per_seed = ";".join(str(v) for v in rec["values"])  # in the order of `sources`
            writer.writerow([" / ".join(labels), column, *numbers, *paper, per_seed, ";".join(rec["sources"])])
    return out.getvalue()


def significant(value):
    """A float kept to `SIGNIFICANT` digits (a std of 8.640987597877148 is 8.64099), anything else as it is."""
    return float(f"{value:.{SIGNIFICANT}g}") if isinstance(value, float) else value


def sidecar(table: Table) -> dict:
    cells = [
        {"row": labels, "column": column, **cell.record()}
        for labels, cells in table.rows
        for column, cell in zip(table.columns, cells, strict=True)
    ]
    return {"table": table.name, "title": table.heading, "setup": table.setup, "cells": cells, "missing": table.missing,
            "findings": [f.record() for f in table.findings], "cost": table.cost,
            "made_otherwise": table.otherwise}  # fmt: skip
