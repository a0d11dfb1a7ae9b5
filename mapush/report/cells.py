"""What every table is made of: the paper's numbers and the cells collected from jobs' `result.json` records."""

from __future__ import annotations

from pathlib import Path

import yaml

from mapush.experiments.results import JobResult
from mapush.report import plots
from mapush.report.formats import Cell

PAPER = yaml.safe_load((Path(__file__).with_name("paper.yaml")).read_text())
"""The paper's numbers (`paper.yaml`), which the tables print in parentheses beside ours."""


def matching(results: list[JobResult], **match) -> list[JobResult]:
    """The results whose fields have the values `match` gives (e.g. `method="ours", task="cuboid"`)."""
    return [r for r in results if all(getattr(r, k) == v for k, v in match.items())]


def collect(results: list[JobResult], metric: str, scale: float, **match) -> Cell:
    """The cell of the results that match (key: value or eval name), for one metric of one evaluation."""
    eval_name = match.pop("eval")
    cell = Cell()
    for r in matching(results, **match):
        if eval_name in r.evals:
            cell.values.append(scale * r.evals[eval_name][metric])
            cell.sources.append(r.job_dir)
            change = r.made_otherwise
            cell.otherwise += change is not None and change.concerns(r, eval_name)
    return cell


def final_cell(results: list[JobResult], stage: str, scale: float, **match) -> Cell:
    """The cell of the last point of each matching result's own curve of `stage` (`stage_curves`: e.g. the mid
    level alone under a high level, at the end of its budget), for its success rate."""
    cell = Cell()
    for r in matching(results, **match):
        points = ((r.stage_curves or {}).get(stage) or {}).get("points")
        if points:
            cell.values.append(scale * points[-1]["success_rate"])
            cell.sources.append(r.job_dir)
            change = r.made_otherwise
            cell.otherwise += change is not None and change.concerns_stage(r, stage)
    return cell


def reach_cell(results: list[JobResult]) -> Cell:
    """Env-steps (M) to the curve's `reach` success rate, over the seeds of `results`."""
    values, sources, unreached = plots.reach_values(results)
    return Cell(values, sources, digits=2, unreached=unreached)
