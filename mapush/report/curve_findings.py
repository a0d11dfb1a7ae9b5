"""What is read off the learning curves of sweep jobs (`result.json`'s `curve`: the evaluated stage's checkpoints,
evaluated as one of the experiment's evaluations; its `stage_curves`: those of a stage trained before it, on that
stage's own env): the mean curve over seeds, the env-steps to a success rate, and whether a budget has flattened
(`budget_verdict`). `plots.py` draws them."""

from __future__ import annotations

import dataclasses

import numpy as np

from mapush.eval.curve_points import clean_rate, first_reaching, steps_to_reach, tail_gain
from mapush.experiments.job_records import Curve
from mapush.experiments.results import JobResult
from mapush.report.formats import OTHERWISE, Finding, counted


def curve_of(result: JobResult, stage: str | None = None) -> Curve | None:
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
        return change.concerns(result, result.curve.eval or "")
    return change.concerns_stage(result, stage)


def drawn_stages(results: list[JobResult]) -> list[str]:
    """The stages trained before the evaluated one whose own curves some of `results` carry."""
    return sorted({name for r in results for name in (r.stage_curves or {})})


def seed_curves(results: list[JobResult], stage: str | None = None) -> list[list[dict]]:
    """The curve points of each result that has a curve (one list per training seed)."""
    curves = (curve_of(r, stage) for r in results)
    return [c.points for c in curves if c and c.points]


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
        if not curve or not curve.points:
            continue
        hit = first_reaching(curve.points, float(curve.reach))
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
    with_curves = [(r, c) for r, c in ((r, curve_of(r, stage)) for r in results) if c and c.points]
    if not with_curves:
        return None
    curves = [c for _, c in with_curves]
    rule = curves[0].rule
    at_zero = [(r, c) for r, c in with_curves if all(point["success_rate"] == 0 for point in c.points)]
    if len(at_zero) == len(curves):
        checkpoints = sum(len(c.points) for c in curves)
        text = f"{label}: did not learn: 0 % success at every one of {checkpoints} evaluated checkpoints"
        return Finding(text, False, {"checkpoints": checkpoints}, key="budget", about=label)
    gains = [g for g in (tail_gain(c.points, float(rule.tail)) for c in curves) if g is not None]
    if not gains:
        return Finding(f"{label}: too few checkpoints to judge the budget", key="budget", about=label)
    gain, max_gain = clean_rate(np.mean(gains)), clean_rate(rule.max_gain)  # compared as printed
    mean, std, limit = 100 * gain, 100 * clean_rate(np.std(gains)), 100 * max_gain
    numbers = {"tail_gain_points": mean, "tail_gain_std": std, "limit_points": limit}
    if gain >= max_gain:
        verdict = "NOT flattened: still learning"
    elif gain > -max_gain:
        verdict = "flattened"
    else:  # lost as much as the rule lets a flat curve gain: the budget runs past the curve's peak
        x, rates, _ = mean_curve([c.points for c in curves])
        peak = int(np.argmax(rates))
        numbers |= {"peak_sr": 100 * float(rates[peak]), "peak_env_steps": float(x[peak])}
        verdict = (
            f"flattened, then falling: the mean curve peaked at {100 * rates[peak]:.1f} % "
            f"after {x[peak] / 1e6:.1f}M env-steps"
        )
    seeds = counted(len(gains), "seed")
    text = (
        f"{label}: the last {100 * float(rule.tail):.0f} % of the budget added {mean:+.1f} \u00b1 {std:.1f} "
        f"points over {seeds} (rule: < {limit:.0f}): {verdict}"
    )
    if at_zero:  # the mean hides a seed that never learned: say which
        named = ", ".join(f"{r.seed} ({len(c.points)} checkpoints)" for r, c in at_zero)
        text += f"; did not learn (0 % at every checkpoint): {'seeds' if len(at_zero) > 1 else 'seed'} {named}"
        numbers["seeds_not_learned"] = len(at_zero)
    return Finding(text, gain < max_gain, numbers, key="budget", about=label)


def budget_findings(lines: dict[str, list[JobResult]], stages: list[str] = ()) -> list[Finding]:
    """Every table's budget checks: `budget_verdict` of each labelled group of results that has curves, then
    `stage_verdicts` of each over the earlier `stages` (`drawn_stages`)."""
    found = [v for v in (budget_verdict(label, results) for label, results in lines.items()) if v is not None]
    return found + [v for label, results in lines.items() for v in stage_verdicts(label, results, stages)]


def stage_verdicts(label: str, results: list[JobResult], stages: list[str]) -> list[Finding]:
    """`budget_verdict` of each of `stages` that `results` trained before their evaluated stage (the last they
    name), by the stage's own curves, each saying how many of those jobs lack one (their runs were not here)."""
    verdicts = []
    for stage in stages:
        trained = [r for r in results if stage in list(r.stages)[:-1]]
        if not trained:
            continue
        name = f"{label}, {stage} level"
        verdict = budget_verdict(name, trained, stage) or Finding(f"{name}: no curve", key="budget", about=name)
        lacking = sum(curve_of(r, stage) is None for r in trained)
        if lacking:
            why = f" ({lacking} of {len(trained)} jobs have no curve of it: their runs were not here to draw it)"
            numbers = {**verdict.numbers, "jobs_without_curve": lacking}
            verdict = dataclasses.replace(verdict, text=verdict.text + why, numbers=numbers)
        verdicts.append(verdict)
    return verdicts


def steps_to(results: list[JobResult], rate_pct: float) -> tuple[str, float | None]:
    """How many env-steps the mean learning curve of `results` would need to reach `rate_pct`, going on as the last
    stretch of its budget went (`steps_to_reach`), as the end of a finding line, and the number (None: never)."""
    per_seed = seed_curves(results)
    if not per_seed:
        return "", None
    x, rates, _ = mean_curve(per_seed)
    tail = float(next(r.curve for r in results if r.curve).rule.tail)
    points = [{"env_steps": float(e), "success_rate": float(v)} for e, v in zip(x, rates, strict=True)]
    needed = steps_to_reach(points, rate_pct / 100, tail)
    budget = f"{x[-1] / 1e6:.1f}M env-steps"
    if needed is None:
        return f"; its curve does not rise over the last {100 * tail:.0f} % of its {budget}", None
    return (
        f"; its curve still rises: at the rate of its last {100 * tail:.0f} % it would reach that after about "
        f"{needed / 1e6:.0f}M env-steps (its budget: {budget})"
    ), needed


def trained_on(results: list[JobResult], longer: list[JobResult], rate_pct: float) -> tuple[str, dict]:
    """Where the jobs of a longer budget (`longer`) trained the learner of `results` past their budget: the env-steps
    at which their mean curve first reached `rate_pct` and where it ended, as the end of a finding line and its
    numbers (marked when those jobs were made by an earlier recipe); nothing when no longer curve is there."""
    ends = [c.points[-1]["env_steps"] for c in (r.curve for r in results) if c and c.points]
    per_seed = seed_curves(longer)
    if not (ends and per_seed):
        return "", {}
    x, rates, _ = mean_curve(per_seed)
    if x[-1] <= max(ends):
        return "", {}
    variants = ", ".join(sorted({r.variant for r in longer if r.curve}))
    above = [k for k, v in enumerate(rates) if round(100 * v, 1) >= round(rate_pct, 1)]  # compared as printed
    hit = float(x[above[0]]) if above else None
    end = f"{100 * rates[-1]:.1f} % at its end"
    reached = f"never reached that: {end}"
    if above:  # a checkpoint reached it; the curve crossed it since the one before
        before = (
            f"; the one before: {100 * rates[above[0] - 1]:.1f} % at {x[above[0] - 1] / 1e6:.1f}M" if above[0] else ""
        )
        reached = f"first reached that at the checkpoint of {hit / 1e6:.1f}M env-steps ({end}{before})"
    seeds, marked = counted(len(per_seed), "seed"), {}
    if any(curve_made_otherwise(r) for r in longer):  # its cells are marked so in their own table
        seeds, marked = seeds + f", {OTHERWISE} an earlier recipe", {"longer_made_otherwise": 1.0}
    text = f"; trained on to {x[-1] / 1e6:.1f}M env-steps (budget {variants}, {seeds}) it {reached}"
    return text, {
        "env_steps_longer": float(x[-1]),
        "env_steps_to_pusher_longer": hit,
        "sr_longer": 100 * float(rates[-1]),
        **marked,
    }
