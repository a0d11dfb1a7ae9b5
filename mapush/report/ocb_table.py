"""The OCB ablation (paper Table III): Ours with and without the OCB reward, at two timeouts."""

from __future__ import annotations

import numpy as np

from mapush.experiments.results import JobResult
from mapush.report import curve_findings
from mapush.report.cells import PAPER, collect, matching, reach_cell
from mapush.report.formats import OVER_SEEDS, Finding, Table


def ocb_table(results: list[JobResult], variant: str) -> Table:
    """The OCB ablation: rows with and without OCB, columns S.R. and C.T. (s) at each timeout."""
    paper = PAPER["ocb_ablation"]
    mine = matching(results, table="ocb_ablation", variant=variant)
    columns, rows, missing = [], [], []
    for name in paper["evals"]:
        columns += [f"S.R. (%), {paper['eval_labels'][name]}", f"C.T. (s), {paper['eval_labels'][name]}"]
    curve = next((r.curve for r in mine if r.curve), None)
    if curve:
        columns.append(f"Env-steps (M) to {100 * float(curve.reach):.0f} % S.R., {paper['eval_labels'][curve.eval]}")
    for method in paper["methods"]:
        cells = []
        for name in paper["evals"]:
            for metric, key, scale in (
                ("success_rate", "success_rate", 100.0),
                ("completion_time_s", "completion_time_s", 1.0),
            ):
                cell = collect(mine, key, scale, method=method, eval=name)
                cell.paper = tuple(paper[metric][name][method])
                if not cell.values:
                    missing.append(f"{method} / {name} / {metric}: no finished job")
                cells.append(cell)
        if curve:
            cells.append(reach_cell(matching(mine, method=method)))
        rows.append(([paper["labels"][method]], cells))
    arms = {paper["labels"][m]: matching(mine, method=m) for m in paper["methods"]}
    findings = _ocb_findings(paper, columns, rows, arms)
    return Table(
        f"ocb_ablation_{variant}",
        f"OCB ablation ({variant})",
        ["Method"],
        columns,
        rows,
        missing,
        f"Free space, 1.5 m cuboid of 6 kg, 2 robots, subgoals 1.5-3 m away; {OVER_SEEDS}.",
        findings,
        {f"OCB ablation, {paper['eval_labels'][curve.eval]}" if curve else "": arms},
        reading="ours (paper)",
    )


def _ocb_findings(paper: dict, columns: list[str], rows: list, arms: dict[str, list[JobResult]]) -> list[Finding]:
    """The paper's OCB finding (success at each timeout, with against without) checked on our cells, and whether
    each arm's budget has flattened."""
    findings = []
    (_, with_ocb), (_, without) = rows
    for k, name in enumerate(paper["evals"]):
        checks = (
            (2 * k, "success_rate", 1, "gain in S.R.", "points", "ocb_sr_gain"),
            (2 * k + 1, "completion_time_s", -1, "saving in C.T.", "s", "ocb_ct_saving"),
        )
        for column, metric, sign, what, unit, key in checks:
            ours, other = with_ocb[column], without[column]
            if len(ours.values) < 2 or len(other.values) < 2:
                continue
            gain = sign * (ours.mean - other.mean) + 0.0  # no -0.0
            spread = float(np.hypot(ours.std, other.std))
            p_ours, p_other = (paper[metric][name][m][0] for m in paper["methods"])
            holds = True if gain > spread else (False if gain <= 0 else None)  # None: within the seeds' spread
            verdict = {True: "holds", False: "does not hold", None: "is within the seeds' spread"}[holds]
            text = (
                f"{paper['eval_labels'][name]}: the paper's OCB {what} ({p_ours:g} vs {p_other:g}) {verdict} here: "
                f"{gain:+.1f} {unit} (the seeds' spread {spread:.1f}: both arms' stds, in quadrature)"
            )
            numbers = {"gain": gain, "spread": spread, "paper_with": p_ours, "paper_without": p_other}
            findings.append(Finding(text, holds, numbers, key=key, about=paper["eval_labels"][name]))
    if len(columns) > 2 * len(paper["evals"]):  # the env-steps to the curve's success rate, from the curves
        reach = "; ".join(f"{labels[0]} {cells[-1].text()}" for labels, cells in rows)
        findings.append(Finding(f"{columns[-1]} (the paper measured none): {reach}", key="steps_to_reach"))
    findings += curve_findings.budget_findings(arms)
    return findings
