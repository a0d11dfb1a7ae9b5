"""The tables' plots, and what is read off the learning curves of sweep jobs (`result.json`'s `curve`: the
evaluated stage's checkpoints, evaluated as one of the experiment's evaluations; its `stage_curves`: those of a
stage trained before it, on that stage's own env): the env-steps to a success rate, and whether a budget has
flattened."""

from __future__ import annotations

import dataclasses
import textwrap
from pathlib import Path

import numpy as np

from mapush.eval.curve_points import clean_rate, first_reaching, tail_gain
from mapush.experiments.results import JobResult
from mapush.report.formats import OTHERWISE, OTHERWISE_LEGEND, Finding, counted


def curve_of(result: JobResult, stage: str | None = None) -> dict | None:
    """A job's learning curve: its evaluated stage's (`stage` None), or the own curve of the stage named."""
    return result.curve if stage is None else (result.stage_curves or {}).get(stage)


def curve_made_otherwise(result: JobResult, stage: str | None = None) -> bool:
    """Whether the job was made otherwise than its experiment plans now in a way that concerns this curve, as the
    tables mark cells (`Change.concerns`): the evaluated stage's curve as its evaluation, a stage's own as that
    stage (`Change.concerns_stage`)."""
    change = result.made_otherwise
    if change is None or curve_of(result, stage) is None:
        return False
    if stage is None:
        return change.concerns(result, result.curve.get("eval", ""))
    return change.concerns_stage(result, stage)


def drawn_stages(results: list[JobResult]) -> list[str]:
    """The stages trained before the evaluated one whose own curves some of `results` carry."""
    return sorted({name for r in results for name in (r.stage_curves or {})})


def seed_curves(results: list[JobResult], stage: str | None = None) -> list[list[dict]]:
    """The curve points of each result that has a curve (one list per training seed)."""
    curves = (curve_of(r, stage) for r in results)
    return [c["points"] for c in curves if c and c["points"]]


def mean_curve(per_seed: list[list[dict]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(env-steps, mean success, std success) over seeds, at the env-steps every seed was evaluated at."""
    shared = sorted(set.intersection(*(set(p["env_steps"] for p in points) for points in per_seed)))
    rates = np.array([[{p["env_steps"]: p["success_rate"] for p in points}[x] for x in shared] for points in per_seed])
    return np.array(shared, dtype=float), rates.mean(0), rates.std(0)


def reach_values(results: list[JobResult]) -> tuple[list[float], list[str], int]:
    """Env-steps (millions) at which each result's curve first reached its `reach` success rate, the job dirs of
    those, and how many curves never reached it."""
    values, sources, unreached = [], [], 0
    for r in results:
        curve = r.curve
        if not curve or not curve["points"]:
            continue
        hit = first_reaching(curve["points"], float(curve["reach"]))
        if hit is None:
            unreached += 1
        else:
            values.append(hit["env_steps"] / 1e6)
            sources.append(r.job_dir)
    return values, sources, unreached


def budget_verdict(label: str, results: list[JobResult], stage: str | None = None) -> Finding | None:
    """Whether the budget of `results` (of their evaluated stage, or of `stage`) has flattened by their
    experiment's rule, or whether they did not learn at all (0 % at every checkpoint: a flat curve at 0 is no
    budget that has done its work) (the success gained over the last `tail` of the env-steps, mean over seeds, below
    `max_gain`), and where the mean curve peaked when that tail lost `max_gain` or more (a budget past the peak is
    no better than a shorter one); None without curves. It holds when the budget has flattened (and learned)."""
    curves = [c for c in (curve_of(r, stage) for r in results) if c and c["points"]]
    if not curves:
        return None
    rule = curves[0]["rule"]
    if all(point["success_rate"] == 0 for c in curves for point in c["points"]):
        checkpoints = sum(len(c["points"]) for c in curves)
        text = f"{label}: did not learn: 0 % success at every one of {checkpoints} evaluated checkpoints"
        return Finding(text, False, {"checkpoints": checkpoints})
    gains = [g for g in (tail_gain(c["points"], float(rule["tail"])) for c in curves) if g is not None]
    if not gains:
        return Finding(f"{label}: too few checkpoints to judge the budget")
    gain, max_gain = clean_rate(np.mean(gains)), clean_rate(rule["max_gain"])  # compared as printed
    mean, std, limit = 100 * gain, 100 * clean_rate(np.std(gains)), 100 * max_gain
    numbers = {"tail_gain_points": mean, "tail_gain_std": std, "limit_points": limit}
    if gain >= max_gain:
        verdict = "NOT flattened: still learning"
    elif gain > -max_gain:
        verdict = "flattened"
    else:  # lost as much as the rule lets a flat curve gain: the budget runs past the curve's peak
        x, rates, _ = mean_curve([c["points"] for c in curves])
        peak = int(np.argmax(rates))
        verdict = (
            f"flattened, then falling: the mean curve peaked at {100 * rates[peak]:.1f} % "
            f"after {x[peak] / 1e6:.1f}M env-steps"
        )
    seeds = counted(len(gains), "seed")
    text = (
        f"{label}: the last {100 * float(rule['tail']):.0f} % of the budget added {mean:+.1f} \u00b1 {std:.1f} "
        f"points over {seeds} (rule: < {limit:.0f}): {verdict}"
    )
    return Finding(text, gain < max_gain, numbers)


def stage_verdicts(label: str, results: list[JobResult], stages: list[str]) -> list[Finding]:
    """`budget_verdict` of each of `stages` that `results` trained before their evaluated stage (the last they
    name), by the stage's own curves, each saying how many of those jobs lack one (their runs were not here)."""
    verdicts = []
    for stage in stages:
        trained = [r for r in results if stage in list(r.stages)[:-1]]
        if not trained:
            continue
        name = f"{label}, {stage} level"
        verdict = budget_verdict(name, trained, stage) or Finding(f"{name}: no curve")
        lacking = sum(curve_of(r, stage) is None for r in trained)
        if lacking:
            why = f" ({lacking} of {len(trained)} jobs have no curve of it: their runs were not here to draw it)"
            verdict = dataclasses.replace(verdict, text=verdict.text + why)
        verdicts.append(verdict)
    return verdicts


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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
            line_label = f"{label} ({len(per_seed)} seeds)" + (f" {OTHERWISE}" if (panel, label) in otherwise else "")
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


def scale_plot(table, path: Path) -> None:
    """S.R. (the hierarchy's and the mid level's) and C.T. against the number of robots, with std error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    counts = [int(labels[0]) for labels, _ in table.rows]
    series = ((axes[0], 0, "hierarchy"), (axes[0], 2, "mid level"), (axes[1], 1, "hierarchy"))
    for ax, k, name in series:
        pts = [
            (n, np.mean(cells[k].values), np.std(cells[k].values))
            for n, (_, cells) in zip(counts, table.rows, strict=True)
            if len(cells) > k and cells[k].values
        ]
        if pts:
            n, m, s = zip(*pts, strict=True)
            ax.errorbar(n, m, yerr=s, marker="o", capsize=3, label=name)
    for ax, label in ((axes[0], "S.R. (%)"), (axes[1], "C.T. (normalized)")):
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
