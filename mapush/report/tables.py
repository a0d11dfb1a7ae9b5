"""`mapush tables`: the paper's tables as Markdown, LaTeX (booktabs) and CSV, built from sweep jobs' results.

Every cell is the mean +- std over training seeds of the jobs' `result.json` evaluations (under `runs/` and the
archive of results that `mapush archive` keeps in git, `results/jobs/`); its sidecar
`<table>.json` names the job dirs behind it. A cell with no finished job is marked with an em dash and listed
with the reason. The paper's numbers (`paper.yaml`) stand beside ours where the paper has them.

One module builds each table (`main_table.py`, `team_table.py`, from the cells of `cells.py`), or one file declares
it (`declared/*.yaml`, built by `declared.py`: the OCB ablation, the scalability study, one robot against a team, the
ladder); this one writes them all in every format (`BUILDERS`).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path

from mapush.atomic import write_json, write_text
from mapush.experiments.archive import check_results, load_results
from mapush.experiments.results import JobResult
from mapush.report import curve_findings, declared, plots
from mapush.report.cells import matching, setup_of
from mapush.report.cost import cost_after, cost_by, measured_cost
from mapush.report.formats import Table, csv_text, latex, markdown, sidecar
from mapush.report.main_table import main_table
from mapush.report.team_table import team_table

BUILDERS = {
    "main": main_table,
    "team": team_table,
}
"""Each table `mapush tables` writes, by the `table` its experiment names; a builder returns None for a variant that
makes no table of its own."""
BUILDERS = dict(sorted({**BUILDERS, **declared.builders(taken=tuple(BUILDERS))}.items()))
"""And each table declared in `declared/*.yaml`, by its `name` (`declared.py`; the ladder names no jobs of its own: it
reads the main table's, the scalability study's and the OCB ablation's); all by name."""
SUMMARY_PLOTS = {"scale": plots.scale_plot, "team": plots.team_plot, "ladder": plots.ladder_plot}
"""The tables drawn as a figure of their own (`<table>.png`) besides their learning curves."""


def filled_cells(table: Table) -> int:
    """How many of the table's cells have a value."""
    return sum(bool(cell.values) for _, cells in table.rows for cell in cells)


def filled_before(sidecar_path: Path) -> int:
    """Filled cells of the table an earlier `mapush tables` wrote (its sidecar at `sidecar_path`); 0 for none."""
    try:
        return sum(cell.get("mean") is not None for cell in json.loads(Path(sidecar_path).read_text())["cells"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0


def write_tables(
    roots: list[Path], out: Path, kinds: list[str] | None = None, overwrite: bool = False
) -> tuple[list[Table], list[tuple[Table, int]]]:
    """Write every table of every sweep variant under the `roots` (runs dirs, archives) to `out`; the quick
    budget's even when empty. Returns the tables written and those kept: where `out` already holds the table with
    more filled cells than these runs give (runs lost, or another machine's), it is left as it is unless
    `overwrite`; each kept table comes with its earlier count.

    A variant is a budget plus any stage overrides of the sweep (`result.json`'s `variant`), so that a smoke or
    a modified sweep never mixes with the plain one.
    """
    results = load_results(roots)
    out.mkdir(parents=True, exist_ok=True)
    check_results(results)
    variants = sorted({r.variant for r in results} | {"quick"})
    tables, kept, drawn = [], [], []
    with drawing_pool() as pool:  # each table's figures are drawn while the next table is built
        for variant in variants:
            present = {r.table for r in results if r.variant == variant}
            for kind, build in BUILDERS.items():
                if (kinds is not None and kind not in kinds) or (variant != "quick" and kind not in present):
                    continue
                table = build(results, variant)
                if table is None:  # the variant is another table's reference, not a table of its own
                    continue
                earlier = filled_before(out / f"{table.name}.json")
                if earlier > filled_cells(table) and not overwrite:
                    kept.append((table, earlier))
                    continue
                behind = matching(results, table=kind, variant=variant) + table.also_behind  # each in its cost
                others = [r for r in results if r.table != kind and r.variant == variant]
                _write_table(table, behind, others, out)
                drawn += [pool.submit(draw, *args) for draw, args in _figures(table, kind, behind, out)]
                tables.append(table)
        for figure in drawn:
            figure.result()  # a figure that failed raises here
    return tables, kept


def _write_table(table: Table, behind: list[JobResult], others: list[JobResult], out: Path) -> None:
    """The table's setup, cost lines and what was made otherwise, from the jobs `behind` it (`others`: the other
    tables' jobs of its variant, for what it adds after them), then its md, tex, csv and json."""
    table.otherwise = [f"{Path(r.job_dir).name}: {r.made_otherwise}" for r in behind if r.made_otherwise]
    table.setup = setup_of(behind)
    table.cost = measured_cost(behind)
    table.cost["by_method"] = cost_by(behind, "method_label", table.cost["cores"])
    table.cost["after"] = cost_after(behind, others, table.cost["cores"])
    write_text(out / f"{table.name}.md", markdown(table))
    write_text(out / f"{table.name}.tex", latex(table))
    write_text(out / f"{table.name}.csv", csv_text(table))
    write_json(out / f"{table.name}.json", sidecar(table))


def _figures(table: Table, kind: str, behind: list[JobResult], out: Path) -> list[tuple[Callable, tuple]]:
    """The table's figures to draw, each as (function, arguments): its own figure where it has one
    (`SUMMARY_PLOTS`), its learning curves, and the own curves of each stage trained under the evaluated one."""
    figures: list[tuple[Callable, tuple]] = []
    if kind in SUMMARY_PLOTS:
        figures.append((SUMMARY_PLOTS[kind], (table, out / f"{table.name}.png")))
    title = f"{table.title}: learning curves, evaluated checkpoints"
    figures.append((plots.curves_plot, (table.curves, out / f"{table.name}_curves.png", title)))
    for stage in curve_findings.drawn_stages(behind):  # a stage trained under the evaluated one, on its own env
        title = f"{table.title}: the {stage} level's own learning curves, evaluated checkpoints"
        figures.append((plots.curves_plot, (table.curves, out / f"{table.name}_{stage}_curves.png", title, stage)))
    return figures


class _Inline:
    """An executor that runs each call as it is submitted (one core, or no `fork`)."""

    def __enter__(self) -> _Inline:
        return self

    def __exit__(self, *_) -> None:
        return None

    def submit(self, function: Callable, *args) -> Future:
        done: Future = Future()
        done.set_result(function(*args))
        return done


def drawing_pool():
    """Where the figures are drawn: forked worker processes, one per core up to `DRAWING_WORKERS`, beside this one
    (drawing the figures takes longer than building the tables), else here, in turn: on one core, without `fork`,
    or in a process that has imported PyTorch (`mapush reproduce` after training in process), whose thread pools a
    fork does not carry safely. The workers end with the `with` block that holds them."""
    cores = min(os.cpu_count() or 1, DRAWING_WORKERS)
    if cores < 2 or "fork" not in multiprocessing.get_all_start_methods() or "torch" in sys.modules:
        return _Inline()
    return ProcessPoolExecutor(max_workers=cores, mp_context=multiprocessing.get_context("fork"))


DRAWING_WORKERS = 4
"""At most this many processes draw the figures (about 15 PNGs)."""
