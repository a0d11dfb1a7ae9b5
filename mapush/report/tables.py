"""`mapush tables`: the paper's tables as Markdown, LaTeX (booktabs) and CSV, built from sweep jobs' results.

Every cell is the mean +- std over training seeds of the jobs' `result.json` evaluations (under `runs/` and the
archive of results that `mapush archive` keeps in git, `results/jobs/`); its sidecar
`<table>.json` names the job dirs behind it. A cell with no finished job is marked with an em dash and listed
with the reason. The paper's numbers (`paper.yaml`) stand beside ours where the paper has them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml
from omegaconf import OmegaConf

from mapush.atomic import write_json, write_text
from mapush.config import group_file
from mapush.experiments.archive import load_results, made_otherwise
from mapush.experiments.pipeline import concerns
from mapush.report import plots
from mapush.report.cost import cost_after, cost_by, measured_cost
from mapush.report.formats import Cell, Table, csv_text, latex, markdown, sidecar

PAPER = yaml.safe_load((Path(__file__).with_name("paper.yaml")).read_text())
SCALE_ROBOTS = list(group_file("experiment", "scale").sweep.agents)
"""The robot counts the scalability study plans (`mapush scale`): rows of its table, finished or not."""


EXTRA_COLUMNS = {
    (method, name): f"{PAPER['main']['labels'][method]}, {spec.column}"
    for name, spec in group_file("experiment", "main").evals.items()
    if not OmegaConf.is_list(spec) and "column" in spec
    for method in spec.methods
}
"""The main table's columns beside the paper's methods, (method, evaluation) -> label: the evaluations of
conf/experiment/main.yaml that name a `column` (path following; the legged Go1s that the paper's robots were)."""


def _matching(results: list[dict], **match) -> list[dict]:
    return [r for r in results if all(r.get(k) == v for k, v in match.items())]


def _collect(results: list[dict], metric: str, scale: float, **match) -> Cell:
    """The cell of the results that match (key: value or eval name), for one metric of one evaluation."""
    eval_name = match.pop("eval")
    cell = Cell()
    for r in _matching(results, **match):
        if eval_name in r["evals"]:
            cell.values.append(scale * r["evals"][eval_name][metric])
            cell.sources.append(r["job_dir"])
            reason = r.get("made_otherwise") or ""
            cell.otherwise += bool(reason) and concerns(reason, r, eval_name)
    return cell


def _reach_cell(results: list[dict]) -> Cell:
    """Env-steps (M) to the curve's `reach` success rate, over the seeds of `results`."""
    values, sources, unreached = plots.reach_values(results)
    return Cell(values, sources, digits=2, unreached=unreached)


def main_table(results: list[dict], variant: str) -> Table:
    """Table II's layout: rows task x metric, columns the methods in the paper's order."""
    paper = PAPER["main"]
    mine = [r for r in results if r["table"] == "main" and r["variant"] == variant]
    methods = paper["methods"]
    rows, missing, findings = [], [], []
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
            for (method, eval_name), column in EXTRA_COLUMNS.items():  # other evaluations (not in the paper)
                extra = _collect(mine, key, scale, method=method, task=task, eval=eval_name)
                extra.digits = digits
                if not extra.values:
                    missing.append(f"{column} / {task} / {metric}: no finished job")
                cells.append(extra)
            rows.append(([paper["task_labels"][task], label], cells))
    panels = {
        paper["task_labels"][task]: {paper["labels"][m]: _matching(mine, method=m, task=task) for m in methods}
        for task in paper["tasks"]
    }
    for task in paper["tasks"]:
        findings += _main_findings(mine, paper, task)
    for task, lines in panels.items():
        findings += filter(None, (plots.budget_verdict(f"{m} / {task}", r) for m, r in lines.items()))
    drawn = plots.drawn_stages(mine)
    for task, lines in panels.items():
        findings += [v for m, r in lines.items() for v in plots.stage_verdicts(f"{m} / {task}", r, drawn)]
    return Table(
        f"main_{variant}",
        f"Main results ({variant}): ours (paper)",
        ["Task", "Metric"],
        [*(paper["labels"][m] for m in methods), *EXTRA_COLUMNS.values()],
        rows,
        sorted(set(missing)),
        "S.R. over the evaluation trials, C.T. normalized by the timeout; mean \u00b1 std over training seeds. "
        "Ours, path only: Ours' hierarchy with every subgoal on the planned path (`level.follow_path=true`), the bar "
        "its learned high level has to clear. Ours, legged: the same policies on Go1s walked by the shipped "
        "locomotion policy (`lowlevel=go1`), the figure to hold against the paper's legged robots; SA, legged: the "
        "single robot on a Go1 likewise.",
        findings,
        panels,
    )


LEGGED_GAP = 10.0
"""Points of S.R. the legged Ours row may lose against the tracker row (the tables issue's target)."""


def success_time(success_rate: float, completion_time: float) -> float | None:
    """The mean completion time of the successful episodes alone, as a fraction of the timeout, from a success rate
    (0-1) and a C.T. that counts every failure as the timeout: C.T. = (1 - S.R.) + S.R. x t. None with no success.
    It puts the paper's C.T. and ours on one footing: how fast the pushes that succeed are."""
    if success_rate <= 0:
        return None
    return (completion_time - (1.0 - success_rate)) / success_rate


def _main_findings(mine: list[dict], paper: dict, task: str) -> list[str]:
    """What holds on one object: Ours against the paper, the baselines, path following and the legged robots."""
    sr = {m: _collect(mine, "success_rate", 100.0, method=m, task=task, eval="main").values for m in paper["methods"]}
    ours = sr["ours"]
    if not ours:
        return []
    mean, label = float(np.mean(ours)), paper["task_labels"][task]
    ct = float(np.mean(_collect(mine, "completion_time", 1.0, method="ours", task=task, eval="main").values))
    paper_sr, paper_ct = paper["success_rate"][task]["ours"][0], paper["completion_time"][task]["ours"][0]
    lines = [
        f"{label}: Ours S.R. {mean:.1f} % vs the paper's {paper_sr:.1f} % ("
        + ("holds: at or above" if mean >= paper_sr else "does not hold: below")
        + f"), C.T. {ct:.2f} vs {paper_ct:.2f} ("
        + ("holds: at or below" if ct <= paper_ct else "does not hold: above")
        + ")"
    ]
    timeouts = {r["evals"].get("main", {}).get("timeout_s") for r in _matching(mine, method="ours", task=task)}
    mine_t, paper_t = success_time(mean / 100, ct), success_time(paper_sr / 100, paper_ct)
    if len(timeouts) == 1 and None not in timeouts and mine_t is not None and paper_t is not None:
        (timeout,) = timeouts
        lines.append(
            f"{label}: Ours' successes take {mine_t * timeout:.0f} s on average, the paper's {paper_t * timeout:.0f} s "
            f"(from S.R. and C.T., a failure counting as the {timeout:.0f} s timeout)"
        )
    beaten = [paper["labels"][m] for m, v in sr.items() if m != "ours" and v and np.mean(v) >= mean]
    below = [paper["labels"][m] for m, v in sr.items() if m != "ours" and v and np.mean(v) < mean]
    if beaten or below:
        lines.append(
            f"{label}: baselines below Ours: {', '.join(below) or 'none'}; at or above: {', '.join(beaten) or 'none'}"
        )
    for eval_name, what in (("path_only", "path following"), ("go1", "legged Go1s")):
        other = _collect(mine, "success_rate", 100.0, method="ours", task=task, eval=eval_name).values
        if not other:
            continue
        gap = mean - float(np.mean(other))
        if eval_name == "path_only":
            verdict = "adds to" if gap > 0 else "does not beat"
            lines.append(f"{label}: the learned high level {verdict} path following ({gap:+.1f} points of S.R.)")
        else:
            verdict = "within" if gap <= LEGGED_GAP else "not within"
            line = f"{label}: on {what} Ours loses {gap:.1f} points of S.R., {verdict} {LEGGED_GAP:g} points"
            lines.append(line + _ended_by(mine, task, eval_name))
    lines += _legged_baseline(mine, paper, task)
    return lines


def _legged_baseline(mine: list[dict], paper: dict, task: str) -> list[str]:
    """The paper's comparison on legs: each baseline evaluated on Go1s (`go1`) against Ours on Go1s."""
    ours = _collect(mine, "success_rate", 100.0, method="ours", task=task, eval="go1").values
    if not ours:
        return []
    lines, ours_mean = [], float(np.mean(ours))
    for method in (m for m in paper["methods"] if m != "ours"):
        legged = _collect(mine, "success_rate", 100.0, method=method, task=task, eval="go1").values
        if legged:
            mean = float(np.mean(legged))
            verdict = "below" if mean < ours_mean else "at or above"
            lines.append(
                f"{paper['task_labels'][task]}: on legged Go1s {paper['labels'][method]} reaches {mean:.1f} % of "
                f"S.R., {verdict} Ours' {ours_mean:.1f} %"
            )
    return lines


def _ended_by(results: list[dict], task: str, eval_name: str) -> str:
    """The end of a finding line: which exceptions ended the evaluation's episodes, where its records name them."""
    shares = [r["evals"][eval_name]["exceptions"] for r in _matching(results, method="ours", task=task)
              if "exceptions" in r["evals"].get(eval_name, {})]  # fmt: skip
    if not shares:
        return ""
    mean = {kind: 100.0 * float(np.mean([s[kind] for s in shares])) for kind in shares[0]}
    named = [f"{kind} {share:.0f} %" for kind, share in sorted(mean.items(), key=lambda kv: -kv[1]) if share > 0]
    return f"; episodes ended by {', '.join(named)} (mean over {len(shares)} seeds)" if named else ""


def ocb_table(results: list[dict], variant: str) -> Table:
    """The OCB ablation: rows with and without OCB, columns S.R. and C.T. (s) at each timeout."""
    paper = PAPER["ocb_ablation"]
    mine = [r for r in results if r["table"] == "ocb_ablation" and r["variant"] == variant]
    columns, rows, missing = [], [], []
    for name in paper["evals"]:
        columns += [f"S.R. (%), {paper['eval_labels'][name]}", f"C.T. (s), {paper['eval_labels'][name]}"]
    curve = next((r["curve"] for r in mine if r.get("curve")), None)
    if curve:
        columns.append(
            f"Env-steps (M) to {100 * float(curve['reach']):.0f} % S.R., {paper['eval_labels'][curve['eval']]}"
        )
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
        if curve:
            cells.append(_reach_cell(_matching(mine, method=method)))
        rows.append(([paper["labels"][method]], cells))
    arms = {paper["labels"][m]: _matching(mine, method=m) for m in paper["methods"]}
    findings = _ocb_findings(paper, columns, rows, arms)
    return Table(
        f"ocb_ablation_{variant}",
        f"OCB ablation ({variant}): ours (paper)",
        ["Method"],
        columns,
        rows,
        missing,
        "Free space, 1.5 m cuboid of 6 kg, 2 robots, subgoals 1.5-3 m away; mean \u00b1 std over training seeds.",
        findings,
        {f"OCB ablation, {paper['eval_labels'][curve['eval']]}" if curve else "": arms},
    )


def _ocb_findings(paper: dict, columns: list[str], rows: list, arms: dict[str, list[dict]]) -> list[str]:
    """The paper's OCB finding (success at each timeout, with against without) checked on our cells, and whether
    each arm's budget has flattened."""
    findings = []
    (_, with_ocb), (_, without) = rows
    for k, name in enumerate(paper["evals"]):
        checks = (
            (2 * k, "success_rate", 1, "gain in S.R.", "points"),
            (2 * k + 1, "completion_time_s", -1, "saving in C.T.", "s"),
        )
        for column, metric, sign, what, unit in checks:
            ours, other = with_ocb[column], without[column]
            if len(ours.values) < 2 or len(other.values) < 2:
                continue
            gain = float(sign * (np.mean(ours.values) - np.mean(other.values))) + 0.0  # no -0.0
            spread = float(np.hypot(np.std(ours.values), np.std(other.values)))
            p_ours, p_other = (paper[metric][name][m][0] for m in paper["methods"])
            verdict = "holds" if gain > spread else ("does not hold" if gain <= 0 else "is within the seeds' spread")
            findings.append(
                f"{paper['eval_labels'][name]}: the paper's OCB {what} ({p_ours:g} vs {p_other:g}) {verdict} here: "
                f"{gain:+.1f} {unit} (std over seeds {spread:.1f})"
            )
    if len(columns) > 2 * len(paper["evals"]):  # the env-steps to the curve's success rate, from the curves
        reach = "; ".join(f"{labels[0]} {cells[-1].text()}" for labels, cells in rows)
        findings.append(f"{columns[-1]} (the paper measured none): {reach}")
    findings += filter(None, (plots.budget_verdict(label, results) for label, results in arms.items()))
    return findings


def _robots(n: int) -> str:
    return f"{n} robot" + ("s" if n != 1 else "")


def scale_table(results: list[dict], variant: str) -> Table:
    """Scalability: rows the robot counts (the paper's, the study's and any run), columns the hierarchy's S.R. and
    C.T. and the mid level's own S.R. (the paper: a figure)."""
    mine = [r for r in results if r["table"] == "scale" and r["variant"] == variant]
    counts = sorted(set(PAPER["scale"]["robots"]) | set(SCALE_ROBOTS) | {r["num_agents"] for r in mine})
    rows, missing = [], []
    for n in counts:
        cells = [
            _collect(mine, "success_rate", 100.0, num_agents=n, eval="main"),
            _collect(mine, "completion_time", 1.0, num_agents=n, eval="main"),
            _collect(mine, "success_rate", 100.0, num_agents=n, eval="mid"),
        ]
        cells[1].digits = 2
        if not cells[0].values:
            missing.append(f"{_robots(n)}: no finished job")
        elif not cells[2].values:
            missing.append(f"{_robots(n)} / mid level: no evaluation of the mid level alone")
        rows.append(([str(n)], cells))
    findings = []
    measured = [(np.mean(c[0].values), np.std(c[0].values), labels[0]) for labels, c in rows if c[0].values]
    if measured:
        top = max(m[0] for m in measured)
        best = [f"{n} ({mean:.1f} \u00b1 {std:.1f} % S.R.)" for mean, std, n in measured if np.isclose(mean, top)]
        among = "" if len(measured) == len(rows) else f" of those finished ({', '.join(m[2] for m in measured)})"
        findings.append(f"Best robot count{among} here: {' and '.join(best)}" + (", tied" if len(best) > 1 else ""))
    findings += _scale_paper_findings(rows) + _reference_mid_finding(rows)
    lines = {_robots(n): _matching(mine, num_agents=n) for n in counts}
    findings += filter(None, (plots.budget_verdict(label, r) for label, r in lines.items()))
    drawn = plots.drawn_stages(mine)
    findings += [v for label, r in lines.items() for v in plots.stage_verdicts(label, r, drawn)]
    return Table(
        f"scale_{variant}",
        f"Scalability, cylinder ({variant})",
        ["Robots"],
        ["S.R. (%) \u2191", "C.T. \u2193", "Mid level S.R. (%) \u2191"],
        rows,
        missing,
        "Whole hierarchy; C.T. normalized by the timeout; mean \u00b1 std over training seeds. Mid level: the "
        "same jobs' mid level alone on its 20 s pushes. The paper gives a figure only.",
        findings,
        {"Cylinder": lines},
    )


def _scale_paper_findings(rows: list) -> list[str]:
    """The paper's four readings of its scalability figure (paper IV-B-3; it gives no numbers), each judged on the
    means over seeds of the whole hierarchy (S.R., and C.T. where the paper says "both metrics") and of the mid
    level alone (S.R.), among the figure's robot counts that finished."""
    figure = PAPER["scale"]["robots"]

    def means(column: int) -> dict[int, float]:
        return {int(labels[0]): float(np.mean(c[column].values)) for labels, c in rows
                if c[column].values and int(labels[0]) in figure}  # fmt: skip

    def spread(column: int, n: int) -> float:
        return next(float(np.std(c[column].values)) for labels, c in rows if int(labels[0]) == n)

    ct = means(1)

    def one_struggles(sr: dict, column: int) -> tuple[bool, str] | None:
        if 1 not in sr or len(sr) < 2:
            return None
        others = {n: v for n, v in sr.items() if n != 1}
        low = min(others, key=others.get)
        return sr[1] < others[low], f"1 robot {sr[1]:.1f} %, the lowest other: {_robots(low)} at {others[low]:.1f} %"

    def two_improve(sr: dict, column: int) -> tuple[bool, str] | None:
        if not {1, 2} <= sr.keys():
            return None
        gain, noise = sr[2] - sr[1], max(spread(column, 1), spread(column, 2))
        return gain > noise, f"{gain:+.1f} points, the seeds' spread {noise:.1f}"

    def three_best(sr: dict, column: int) -> tuple[bool, str] | None:
        if 3 not in sr or len(sr) < 2:
            return None
        best = max(sr, key=sr.get)
        holds, detail = best == 3, f"the highest S.R.: {_robots(best)}"
        if column == 0 and 3 in ct:
            fastest = min(ct, key=ct.get)
            holds, detail = holds and fastest == 3, f"{detail}; the lowest C.T.: {_robots(fastest)}"
        return holds, detail

    def four_worse(sr: dict, column: int) -> tuple[bool, str] | None:
        if not {3, 4} <= sr.keys():
            return None
        return sr[4] < sr[3], f"{sr[4] - sr[3]:+.1f} points from 3 robots to 4"

    claims = {
        "one robot struggles": one_struggles,
        "two robots improve S.R. substantially on one": two_improve,
        "three robots are best on both metrics": three_best,
        "four robots do slightly worse than three": four_worse,
    }
    judged = {0: ("whole hierarchy", means(0)), 2: ("mid level alone", means(2))}
    lines = []
    for claim, judge in claims.items():
        parts = []
        for column, (what, sr) in judged.items():
            verdict = judge(sr, column)
            if verdict is not None:
                parts.append(f"{what}: {'holds' if verdict[0] else 'does not hold'} ({verdict[1]})")
        if parts:
            lines.append(f"The paper ({', '.join(map(str, figure))} robots): {claim}. Here, {'; '.join(parts)}")
    return lines


def _reference_mid_finding(rows: list) -> list[str]:
    """The mid level at the reference robot count against the original's best stored cylinder mid level."""
    ref = PAPER["scale"]["reference_mid"]
    values = next((cells[2].values for labels, cells in rows if labels[0] == str(ref["robots"])), [])
    if not values:
        return []
    mean, std, bar = float(np.mean(values)), float(np.std(values)), float(ref["success_rate"])
    verdict = "at or above it" if mean >= bar else ("below it, within the seeds' spread" if bar - mean <= std
                                                    else "below it")  # fmt: skip
    return [
        f"Mid level with {ref['robots']} robots: {mean:.1f} \u00b1 {std:.1f} % S.R. over {len(values)} seeds; "
        f"the original's best stored cylinder mid level reached {bar:g} %: {verdict}"
    ]


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
    for r in results:
        r["made_otherwise"] = made_otherwise(r)
    variants = sorted({r["variant"] for r in results} | {"quick"})
    out.mkdir(parents=True, exist_ok=True)
    tables, kept = [], []
    for variant in variants:
        present = {r["table"] for r in results if r["variant"] == variant}
        for kind, build in BUILDERS.items():
            if (kinds is not None and kind not in kinds) or (variant != "quick" and kind not in present):
                continue
            table = build(results, variant)
            earlier = filled_before(out / f"{table.name}.json")
            if earlier > filled_cells(table) and not overwrite:
                kept.append((table, earlier))
                continue
            behind = [r for r in results if r["table"] == kind and r["variant"] == variant]
            table.otherwise = [
                f"{Path(r['job_dir']).name}: {r['made_otherwise']}" for r in behind if r["made_otherwise"]
            ]
            table.cost = measured_cost(behind)
            table.cost["by_method"] = cost_by(behind, "method_label", table.cost["cores"])
            others = [r for r in results if r["table"] != kind and r["variant"] == variant]
            table.cost["after"] = cost_after(behind, others, table.cost["cores"])
            write_text(out / f"{table.name}.md", markdown(table))
            write_text(out / f"{table.name}.tex", latex(table))
            write_text(out / f"{table.name}.csv", csv_text(table))
            write_json(out / f"{table.name}.json", sidecar(table))
            if kind == "scale":
                plots.scale_plot(table, out / f"{table.name}.png")
            title = f"{table.title.split(':')[0]}: learning curves, evaluated checkpoints"
            plots.curves_plot(table.curves, out / f"{table.name}_curves.png", title)
            for stage in plots.drawn_stages(behind):  # a stage trained under the evaluated one, on its own env
                title = f"{table.title.split(':')[0]}: the {stage} level's own learning curves, evaluated checkpoints"
                plots.curves_plot(table.curves, out / f"{table.name}_{stage}_curves.png", title, stage)
            tables.append(table)
    return tables, kept


BUILDERS = {"main": main_table, "ocb_ablation": ocb_table, "scale": scale_table}
"""Each table `mapush tables` writes, by the `table` its experiment names."""
