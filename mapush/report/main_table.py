"""The main table (paper Table II): every method on the three long-horizon objects, and what holds of the
paper's findings there."""

from __future__ import annotations

import numpy as np
from omegaconf import OmegaConf

from mapush.config import group_file
from mapush.experiments.results import JobResult
from mapush.report import curve_findings
from mapush.report.cells import (
    PAPER,
    collect,
    event_shares,
    events_finding,
    exception_shares,
    fall_split_finding,
    matching,
    named_shares,
    success_time,
)
from mapush.report.formats import OVER_SEEDS, Finding, Table, counted
from mapush.report.physics import known_physics, team_needed

EXTRA_COLUMNS = {
    (method, name): f"{PAPER['main']['labels'][method]}, {spec.column}"
    for name, spec in group_file("experiment", "main").evals.items()
    if not OmegaConf.is_list(spec) and "column" in spec
    for method in spec.methods
}
"""The main table's columns beside the paper's methods, (method, evaluation) -> label: the evaluations of
conf/experiment/main.yaml that name a `column` (path following; the legged Go1s that the paper's robots were)."""


def with_yours(results: list[JobResult]) -> dict:
    """The paper's Table II layout (`paper.yaml`'s main part) with the methods and tasks of `results` it lacks (a
    method or task of yours) after its own, labelled by the method's `label` or the task's name; they have no
    paper numbers."""
    paper = PAPER["main"]
    methods = [*paper["methods"], *sorted({r.method for r in results} - set(paper["methods"]))]
    tasks = [*paper["tasks"], *sorted({r.task for r in results} - set(paper["tasks"]))]
    yours = {m: next((r.method_label for r in results if r.method == m and r.method_label), m)
             for m in methods if m not in paper["labels"]}  # fmt: skip
    return {
        **paper,
        "methods": methods,
        "tasks": tasks,
        "labels": {**paper["labels"], **yours},
        "task_labels": {**{t: t for t in tasks}, **paper["task_labels"]},
    }


def main_table(results: list[JobResult], variant: str) -> Table:
    """Table II's layout: rows task x metric, columns the methods in the paper's order (then any of yours)."""
    mine = matching(results, table="main", variant=variant)
    paper = with_yours(mine)
    methods = paper["methods"]
    rows, missing, findings = [], [], []
    ran = {(r.method, r.task) for r in mine}  # a side variant (another budget, a stage override) runs a few of the
    # methods and objects: its missing list names only theirs, not the 50-odd cells it never meant to fill
    listed = (lambda method, task: True) if variant == "quick" else (lambda method, task: (method, task) in ran)
    for task in paper["tasks"]:
        for metric, key, scale, digits, label in (
            ("success_rate", "success_rate", 100.0, 1, "S.R. (%) \u2191"),
            ("completion_time", "completion_time", 1.0, 2, "C.T. \u2193"),
        ):
            cells = []
            for method in methods:
                cell = collect(mine, key, scale, method=method, task=task, eval="main")
                published = paper[metric].get(task, {}).get(method)
                cell.paper, cell.digits = (tuple(published) if published else None), digits
                if not cell.values and listed(method, task):
                    missing.append(f"{method} / {task} / {metric}: no finished job")
                cells.append(cell)
            for (method, eval_name), column in EXTRA_COLUMNS.items():  # other evaluations (not in the paper)
                extra = collect(mine, key, scale, method=method, task=task, eval=eval_name)
                extra.digits = digits
                if not extra.values and listed(method, task):
                    missing.append(f"{column} / {task} / {metric}: no finished job")
                cells.append(extra)
            rows.append(([paper["task_labels"][task], label], cells))
    panels = {
        paper["task_labels"][task]: {paper["labels"][m]: matching(mine, method=m, task=task) for m in methods}
        for task in paper["tasks"]
    }
    longer = [r for r in matching(results, table="main") if r.variant != variant]  # a budget that trained on
    for task in paper["tasks"]:
        findings += _main_findings(mine, paper, task, longer)
    labelled = {f"{m} / {task}": r for task, lines in panels.items() for m, r in lines.items()}
    findings += curve_findings.budget_findings(labelled, curve_findings.drawn_stages(mine))
    return Table(
        f"main_{variant}",
        f"Main results ({variant})",
        ["Task", "Metric"],
        [*(paper["labels"][m] for m in methods), *EXTRA_COLUMNS.values()],
        rows,
        sorted(set(missing)),
        f"S.R. over the evaluation trials, C.T. normalized by the timeout; {OVER_SEEDS}. "
        "Ours, path only: Ours' hierarchy with every subgoal on the planned path (`level.follow_path=true`), the bar "
        "its learned high level has to clear. H+L, path only: a hand-written pusher in H+L's action space, each robot "
        "led along the planned path (`level.follow_path=true` on `level=high_nav`), the bar H+L and H+L FT have to "
        "clear; it learns nothing, so its seeds (H+L's jobs) repeat one evaluation. Ours, legged: the same "
        "policies on Go1s walked by the shipped locomotion policy (`lowlevel=go1`), the figure to hold against the "
        "paper's legged robots; SA, legged: the single robot on a Go1 likewise.",
        findings,
        panels,
        reading="ours (paper)",
    )


LEGGED_GAP = 10.0
"""Points of S.R. the legged Ours row may lose against the tracker row before the table says the tracker does not
stand for the Go1 (mapush's own bar: the paper has no tracker)."""


def _main_findings(mine: list[JobResult], paper: dict, task: str, longer: list[JobResult] = ()) -> list[Finding]:
    """What holds on one object: Ours against the paper, the baselines, path following and the legged robots;
    `longer`: the main table's jobs of other budgets, read where a learner stayed below the pusher."""
    sr = {m: collect(mine, "success_rate", 100.0, method=m, task=task, eval="main").values for m in paper["methods"]}
    if not sr["ours"]:
        return []
    mean = float(np.mean(sr["ours"]))
    lines = _against_the_paper(mine, paper, task, mean) if task in paper["success_rate"] else []  # not a task of yours
    lines += _baselines(mine, paper, task, sr, mean) + _learned_against_scripted(mine, paper, task, sr, longer)
    lines += _ours_otherwise(mine, paper, task, mean) + _legged_baseline(mine, paper, task)
    arms = {paper["labels"][m]: matching(mine, method=m, task=task) for m in paper["methods"]}
    lines += fall_split_finding(
        arms, paper["task_labels"][task], paper["success_rate"].get(task, {}).get("ours", [None])[0]
    )
    return lines + _exceptions_finding(mine, paper, task) + events_finding(arms, "main", paper["task_labels"][task])


def _baselines(mine: list[JobResult], paper: dict, task: str, sr: dict, mean: float) -> list[Finding]:
    """The paper's claim that Ours beats every baseline; methods of yours beside it, claiming nothing; SA against
    Ours with the object's drag and one robot's capacity (the paper's reason for a team)."""
    label, lines = paper["task_labels"][task], []
    yours = {m: v for m, v in sr.items() if v and m not in PAPER["main"]["methods"]}
    baselines = {m: v for m, v in sr.items() if m != "ours" and v and m in PAPER["main"]["methods"]}  # the paper's
    beaten = [paper["labels"][m] for m, v in baselines.items() if np.mean(v) >= mean]
    below = [paper["labels"][m] for m, v in baselines.items() if np.mean(v) < mean]
    if beaten or below:
        text = (
            f"{label}: baselines below Ours: {', '.join(below) or 'none'}; at or above: {', '.join(beaten) or 'none'}"
        )
        numbers = {paper["labels"][m]: float(np.mean(v)) for m, v in sr.items() if v and m not in yours}
        lines.append(Finding(text, not beaten, numbers, key="ours_above_baselines", about=label))  # the paper's
    if yours:
        text = "; ".join(f"{paper['labels'][m]} {np.mean(v):.1f} %" for m, v in yours.items())
        numbers = {paper["labels"][m]: float(np.mean(v)) for m, v in yours.items()}
        text = f"{label}: methods of yours, against Ours' {mean:.1f} %: {text}"
        lines.append(Finding(text, None, numbers, key="yours_beside_ours", about=label))
    if sr.get("sa"):
        sa = float(np.mean(sr["sa"]))
        verdict = "below" if sa < mean else "at or above"
        physics = known_physics(matching(mine, method="sa", task=task))  # one robot on the object, as it trained
        need, forces = team_needed(physics) if physics else ("drag not recorded", {})
        text = f"{label}: SA {sa:.1f} % is {verdict} Ours; the object's {need}"
        numbers = {"sa_sr": sa, "ours_sr": mean, **forces}
        lines.append(Finding(text, sa < mean, numbers, key="sa_below_ours", about=label))
    return lines


def _learned_against_scripted(
    mine: list[JobResult], paper: dict, task: str, sr: dict, longer: list[JobResult]
) -> list[Finding]:
    """H+L and H+L FT against the hand-written pusher in their action space, with the env-steps a learner below it
    would need if its curve went on as it ended, and what it reached where a longer budget trained it on."""
    scripted = collect(mine, "success_rate", 100.0, method="hl", task=task, eval="path_only").values
    lines = []
    for method in ("hl", "hl_ft"):
        if not (scripted and sr.get(method)):
            continue
        learned, bar = float(np.mean(sr[method])), float(np.mean(scripted))
        verdict = "at or above" if learned >= bar else "below"
        text = (
            f"{paper['task_labels'][task]}: {paper['labels'][method]} {learned:.1f} % is {verdict} the hand-written "
            f"pusher's {bar:.1f} % in its action space (H+L, path only)"
        )
        numbers = {"learned_sr": learned, "pusher_sr": bar}
        if learned < bar:
            own = matching(mine, method=method, task=task)
            more, needed = curve_findings.steps_to(own, bar)
            if more:
                text, numbers["env_steps_to_pusher"] = text + more, needed
            on, reached = curve_findings.trained_on(own, matching(longer, method=method, task=task), bar)
            text, numbers = text + on, {**numbers, **reached}
        lines.append(
            Finding(text, learned >= bar, numbers, key=f"{method}_vs_pusher", about=paper["task_labels"][task])
        )
    return lines


def _ours_otherwise(mine: list[JobResult], paper: dict, task: str, mean: float) -> list[Finding]:
    """Ours against its own hierarchy following the path (what the learned high level adds) and on legged Go1s
    (what the tracker stands for)."""
    label, lines = paper["task_labels"][task], []
    for eval_name, what in (("path_only", "path following"), ("go1", "legged Go1s")):
        other = collect(mine, "success_rate", 100.0, method="ours", task=task, eval=eval_name).values
        if not other:
            continue
        gap = mean - float(np.mean(other))
        if eval_name == "path_only":
            verdict = "adds to" if gap > 0 else "does not beat"
            text = f"{label}: the learned high level {verdict} path following ({gap:+.1f} points of S.R.)"
            lines.append(Finding(text, gap > 0, {"gap_points": gap}, key="high_level_vs_path", about=label))
        else:
            verdict = "within" if gap <= LEGGED_GAP else "not within"
            change = f"loses {gap:.1f}" if gap >= 0 else f"gains {-gap:.1f}"
            line = f"{label}: on {what} Ours {change} points of S.R., {verdict} {LEGGED_GAP:g} points"
            ended, shares = _ended_by(mine, task, eval_name)
            text, numbers = line + ended, {"gap_points": gap, **{f"ended_by {k}": v for k, v in shares.items()}}
            lines.append(Finding(text, gap <= LEGGED_GAP, numbers, key="legged_gap", about=label))
            lines += _legged_against_the_paper(mine, paper, task, float(np.mean(other)))
    return lines


def _legged_against_the_paper(mine: list[JobResult], paper: dict, task: str, legged: float) -> list[Finding]:
    """Ours on legged Go1s (`legged`, S.R. %) against the paper's legged robots, with how often a robot fell there
    and on the trackers (eval.json's `events`, counted whatever ended the episode): the measured cause in view where
    it stays below."""
    published = paper["success_rate"].get(task, {}).get("ours")
    if not published:
        return []
    label, bar = paper["task_labels"][task], float(published[0])
    ours = matching(mine, method="ours", task=task)
    verdict = "holds: at or above" if legged >= bar else "does not hold: below"
    made_otherwise = collect(mine, "success_rate", 1.0, method="ours", task=task, eval="go1").otherwise
    mark = " \u2020" if made_otherwise else ""  # its cell's mark: an earlier recipe's
    text = f"{label}: Ours{mark} on legged Go1s {legged:.1f} % vs the paper's {bar:.1f} % ({verdict})"
    numbers = {"legged_sr": legged, "paper_sr": bar}
    (go1, go1_seeds), (tracker, _) = event_shares(ours, "go1"), event_shares(ours, "main")
    if "falls" in go1:
        on_trackers = f", on trackers {tracker['falls']:.0f} %" if "falls" in tracker else ""
        text += (
            f"; a robot fell in {go1['falls']:.0f} % of its episodes on Go1s{on_trackers} "
            f"(mean over {counted(go1_seeds, 'seed')})"
        )
        numbers |= {
            "legged_fall_pct": go1["falls"],
            **({"tracker_fall_pct": tracker["falls"]} if "falls" in tracker else {}),
        }
    return [Finding(text, legged >= bar, numbers, key="legged_vs_paper", about=label)]


def _against_the_paper(mine: list[JobResult], paper: dict, task: str, mean: float) -> list[Finding]:
    """Ours' S.R. (`mean`) and C.T. on one of the paper's objects against the paper's; how fast its successes are."""
    label = paper["task_labels"][task]
    ct = collect(mine, "completion_time", 1.0, method="ours", task=task, eval="main").mean
    paper_sr, paper_ct = paper["success_rate"][task]["ours"][0], paper["completion_time"][task]["ours"][0]
    text = (
        f"{label}: Ours S.R. {mean:.1f} % vs the paper's {paper_sr:.1f} % ("
        + ("holds: at or above" if mean >= paper_sr else "does not hold: below")
        + f"), C.T. {ct:.2f} vs {paper_ct:.2f} ("
        + ("holds: at or below" if ct <= paper_ct else "does not hold: above")
        + ")"
    )
    numbers = {"ours_sr": mean, "paper_sr": paper_sr, "ours_ct": ct, "paper_ct": paper_ct}
    lines = [Finding(text, mean >= paper_sr and ct <= paper_ct, numbers, key="ours_vs_paper", about=label)]
    timeouts = {
        r.evals["main"].timeout_s if "main" in r.evals else None for r in matching(mine, method="ours", task=task)
    }
    mine_t, paper_t = success_time(mean / 100, ct), success_time(paper_sr / 100, paper_ct)
    if len(timeouts) == 1 and None not in timeouts and mine_t is not None and paper_t is not None:
        (timeout,) = timeouts
        text = (
            f"{label}: Ours' successes take {mine_t * timeout:.0f} s on average, the paper's {paper_t * timeout:.0f} s "
            f"(from S.R. and C.T., a failure counting as the {timeout:.0f} s timeout)"
        )
        numbers = {"ours_success_s": mine_t * timeout, "paper_success_s": paper_t * timeout}
        lines.append(Finding(text, numbers=numbers, key="success_time", about=label))
    return lines


def _legged_baseline(mine: list[JobResult], paper: dict, task: str) -> list[Finding]:
    """The paper's comparison on legs: each baseline evaluated on Go1s (`go1`) against Ours on Go1s."""
    ours = collect(mine, "success_rate", 100.0, method="ours", task=task, eval="go1").values
    if not ours:
        return []
    lines, ours_mean = [], float(np.mean(ours))
    for method in (m for m in paper["methods"] if m != "ours"):
        legged = collect(mine, "success_rate", 100.0, method=method, task=task, eval="go1").values
        if legged:
            mean = float(np.mean(legged))
            verdict = "below" if mean < ours_mean else "at or above"
            text = (
                f"{paper['task_labels'][task]}: on legged Go1s {paper['labels'][method]} reaches {mean:.1f} % of "
                f"S.R., {verdict} Ours' {ours_mean:.1f} %"
            )
            numbers = {"baseline_sr": mean, "ours_sr": ours_mean}
            about = paper["task_labels"][task]
            lines.append(Finding(text, mean < ours_mean, numbers, key=f"legged_{method}_below_ours", about=about))
    return lines


def _ended_by(results: list[JobResult], task: str, eval_name: str) -> tuple[str, dict[str, float]]:
    """The end of a finding line: which exceptions ended Ours' episodes of the evaluation, where its records name
    them, and their shares (%) by kind."""
    shares, seeds = exception_shares(matching(results, method="ours", task=task), [eval_name])
    return (
        f"; episodes ended by {named_shares(shares)} (mean over {counted(seeds, 'seed')})" if shares else ""
    ), shares


def _exceptions_finding(mine: list[JobResult], paper: dict, task: str) -> list[Finding]:
    """One line per object: what ended each method's episodes of the main evaluation (falls, collisions, ...), so
    a low S.R. reads with its cause; a method whose cell is marked as made otherwise (\u2020) is marked so here."""
    parts, clean, numbers = [], [], {}
    for method in paper["methods"]:
        shares, seeds = exception_shares(matching(mine, method=method, task=task), ["main"])
        otherwise = collect(mine, "success_rate", 1.0, method=method, task=task, eval="main").otherwise
        label = paper["labels"][method] + (" \u2020" if otherwise else "")
        if shares:
            parts.append(f"{label} {named_shares(shares)}")
            numbers.update({f"{label} {kind}": share for kind, share in shares.items()})
        elif seeds:
            clean.append(label)
    if clean:
        parts.append(f"none: {', '.join(clean)}")
    if not parts:
        return []
    text = f"{paper['task_labels'][task]}: episodes ended by an exception (mean over seeds): {'; '.join(parts)}"
    return [Finding(text, numbers=numbers, key="ended_by", about=paper["task_labels"][task])]
