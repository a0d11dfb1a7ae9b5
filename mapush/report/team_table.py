"""The team study's table and heatmaps (`conf/experiment/team.yaml`): per object, the mid level's S.R. for each
robot count (rows) at each object mass (columns), each cell beside its capacity margin: the object's drag over what
its robots push together (`physics.py`). A margin above 1 is a team that cannot move the object even all pushing
at once; well below 1, fewer robots could."""

from __future__ import annotations

import numpy as np

from mapush.config import group_file
from mapush.experiments.results import JobResult
from mapush.report import curve_findings
from mapush.report.cells import collect, matching, named_shares, record_shares
from mapush.report.formats import ALONE, OVER_SEEDS, Finding, Table, counted
from mapush.report.physics import capacity_margin, known_physics

TEAM = group_file("experiment", "team")


def eval_masses(results: list[JobResult]) -> dict[str, float | None]:
    """Each evaluation of the study and the object mass (kg) it set, as its jobs recorded it (`object_mass`); None
    for an evaluation no job made (or none that knows its mass)."""
    return {
        name: next((m for m in (r.object_mass(name) for r in results) if m is not None), None) for name in TEAM.evals
    }


def _kg(name: str, mass: float | None) -> str:
    """A mass column's label: its mass, or the evaluation's name where no job recorded the mass."""
    return name if mass is None else f"{mass:g} kg"


def team_table(results: list[JobResult], variant: str) -> Table | None:
    """Rows (object, robots), columns the evaluated masses; each cell S.R. (%) over seeds, with its margin. A row
    whose robots the study also trained at every evaluated mass alone (`JobResult.trained_mass_kg`, the design
    check) is drawn from those policies, marked ALONE: what a team of that size reaches at each mass, not how well
    one policy learns the range. None for a variant whose every job trained at one mass: those are read by the
    study's own table."""
    mine = matching(results, table="team", variant=variant)
    if mine and all(r.trained_mass_kg() is not None for r in mine):
        return None
    alone = _made_as(results, mine)
    masses = eval_masses(mine + alone)
    physics = {task: known_physics(matching(mine + alone, task=task)) for task in TEAM.sweep.task}
    capacity = next((p.robot_capacity_n for p in physics.values() if p and p.robot_capacity_n is not None), None)
    rows, ranged_rows, alone_rows, missing, drawn, lines, records, alone_lines = [], [], [], [], [], {}, {}, {}
    for task in TEAM.sweep.task:
        for n in TEAM.sweep.agents:
            label = f"{task} / {counted(n, 'robot')}"
            jobs = [r for r in mine if r.task == task and r.num_agents == n]
            lines[label] = jobs
            at = {name: [r for r in matching(alone, task=task, num_agents=n) if r.trained_mass_kg() == mass]
                  for name, mass in masses.items()}  # fmt: skip  # evaluation name: the jobs trained at its mass
            ranged = [collect(jobs, "success_rate", 100.0, eval=name) for name in masses]
            each = [collect(at[name], "success_rate", 100.0, eval=name) for name in masses]
            drawn_alone = all(cell.values for cell in each)
            cells = each if drawn_alone else ranged
            for cell, (name, mass) in zip(cells, masses.items(), strict=True):
                margin = None if physics[task] is None or mass is None else capacity_margin(physics[task], mass, n)
                cell.note = f"margin {margin:.2f}" if margin is not None else ""
                cell.mark = ALONE if drawn_alone else ""
                if jobs and not cell.values:
                    missing.append(f"{label} / {_kg(name, mass)}: no job evaluated it ({name})")
            if not jobs and not drawn_alone:
                missing.append(f"{label}: no finished job")
            if drawn_alone:
                drawn.append(label)
                records[task, n] = [(r, name) for name, behind in at.items() for r in behind]
                alone_lines |= {f"{label} at {_kg(name, masses[name])} alone": behind for name, behind in at.items()
                                if all(_curve_eval(r) == name for r in behind)}  # fmt: skip  # a curve at its own mass
            else:
                records[task, n] = [(r, name) for r in jobs for name in masses]
            rows.append(([task, str(n)], cells))
            ranged_rows.append(([task, str(n)], ranged))
            alone_rows.append(([task, str(n)], each))
    findings = _findings(rows, masses) + _exception_findings(records)
    findings += _one_mass_findings(results, variant, ranged_rows, mine, masses)
    findings += _fixed_mass_findings(alone_rows, ranged_rows, masses, _range_text(mine))
    findings += curve_findings.budget_findings(lines) + curve_findings.budget_findings(alone_lines)
    alone_text = (
        f" {ALONE}: one policy per mass, trained at that mass alone, where the study trained the robot count at every "
        f"mass ({', '.join(drawn)}); the lines below weigh the range's policy against it."
    )
    table = Table(
        f"team_{variant}",
        f"When is a team needed? Mid level, S.R. (%) by object mass ({variant})",
        ["Object", "Robots"],
        [_kg(name, mass) for name, mass in masses.items()],
        rows,
        missing,
        "The mid level alone on its 20 s pushes, one policy per robot count trained over masses of "
        f"{_range_text(mine)} and evaluated at each mass; {OVER_SEEDS}. Margin: the object's "
        f"drag (mass x g x its mean friction) over the robots' summed push capacity ({capacity or 0:.1f} N each, the "
        "calibrated tracker's): above 1 the team cannot move it even all pushing at once."
        + (alone_text if drawn else ""),
        findings,
        {"Team": lines},
    )
    table.also_behind = alone  # the design check's jobs make no table of their own: this one counts their cost
    return table


def _curve_eval(result: JobResult) -> str | None:
    """The evaluation a job's learning curve was measured at (the study's curves are all at one mass)."""
    return result.curve.eval if result.curve else None


def _range_text(mine: list[JobResult]) -> str:
    """The mass range (kg) the study's jobs trained over, as they recorded it."""
    ranged = next((p.mass_range_kg for p in (r.object_physics() for r in mine) if p and p.mass_range_kg), None)
    return "an unrecorded range" if ranged is None else f"{ranged[0]}-{ranged[1]} kg"


def _findings(rows: list, masses: dict[str, float | None]) -> list[Finding]:
    """Per object and mass, the fewest robots that reach half success, and the margin they push at."""
    found = []
    by_task: dict[str, list] = {}
    for (task, n), cells in rows:
        by_task.setdefault(task, []).append((int(n), cells))
    for task, team_rows in by_task.items():
        parts, fewest = [], {}
        for k, (name, mass) in enumerate(masses.items()):
            done = [(n, cells[k]) for n, cells in team_rows if cells[k].values]
            if not done:
                continue
            enough = sorted(((n, c) for n, c in done if c.mean >= 50.0), key=lambda nc: nc[0])  # the fewest first
            at = _kg(name, mass)
            parts.append(f"{at}: {enough[0][0]} ({enough[0][1].bracket})" if enough else f"{at}: none of {len(done)}")
            if enough:
                fewest[f"{at.replace(' ', '_')}_robots"] = enough[0][0]
        if parts:
            text = f"{task}: the fewest robots reaching 50 % S.R. by mass: " + "; ".join(parts)
            found.append(Finding(text, numbers=fewest, key="fewest_robots", about=task))
    return found


def _exception_findings(records: dict[tuple[str, int], list[tuple[JobResult, str]]]) -> list[Finding]:
    """Per object, what ended each robot count's episodes (falls, collisions, ...), over every mass and seed of the
    evaluations its row is drawn from, so a low S.R. reads with its cause (e.g. a crowd that collides at a mass one
    robot pushes)."""
    found = []
    for task in TEAM.sweep.task:
        parts = []
        for n in TEAM.sweep.agents:
            shares, count = record_shares(records.get((task, n), []))
            if count:
                parts.append((counted(n, "robot"), shares))
        if parts:
            text = "; ".join(f"{robots}: {named_shares(shares) or 'none'}" for robots, shares in parts)
            numbers = {f"{robots} {kind}": share for robots, shares in parts for kind, share in shares.items()}
            text = f"{task}: episodes ended by an exception (mean over masses and seeds): {text}"
            found.append(Finding(text, numbers=numbers, key="ended_by", about=task))
    return found


def _one_mass_findings(
    results: list[JobResult], variant: str, rows: list, mine: list[JobResult], masses: dict[str, float | None]
) -> list[Finding]:
    """Per object and robot count, the study's design checked: does a policy trained over the mass range learn as
    well as a mid level of the same object and robots trained at the object's own mass (another table's jobs: the
    main table's, the scalability study's)? The one-mass policy's own curve at the env-steps nearest this study's
    budget, against this study's cells at the evaluated masses either side of that mass. Where the range costs more
    than the seeds' spread, a cell measures how the range trains as well as what a team needs."""
    found = []
    for (task, n), cells in rows:
        references = _one_mass_references(results, variant, task, int(n), {_rules(r) for r in mine})
        own_physics = known_physics(references)  # trained at the object's own mass
        if own_physics is None:
            continue
        own, evaluated = own_physics.mass_kg, list(masses.values())
        below = max((m for m in evaluated if m is not None and m <= own), default=None)
        above = min((m for m in evaluated if m is not None and m >= own), default=None)
        near = [
            k for k, mass in enumerate(evaluated) if mass is not None and mass in (below, above) and cells[k].values
        ]
        jobs = matching(mine, task=task, num_agents=int(n))
        budgets = [r.curve.points[-1]["env_steps"] for r in jobs if r.curve and r.curve.points]
        if not near or not budgets:
            continue
        budget = max(budgets)
        steps, rates, spreads = curve_findings.mean_curve(curve_findings.seed_curves(references, "mid"))
        k = int(np.argmin(np.abs(steps - budget)))  # the one-mass checkpoint nearest this study's budget
        mean, std, at_steps = 100 * float(rates[k]), 100 * float(spreads[k]), steps[k]
        best = max((cells[k] for k in near), key=lambda cell: cell.mean)
        at = ", ".join(f"{cells[k].mean:.1f} % at {evaluated[k]:g} kg" for k in near)
        by = ", ".join(sorted({f"{r.table} {r.method_label or r.method}" for r in references}))
        text = (
            f"{task} / {counted(int(n), 'robot')}: trained over {_range_text(mine)}, {at} after {budget / 1e6:.1f}M "
            f"env-steps; trained at its own {own:g} kg ({by}, {counted(len(references), 'seed')}), "
            f"{mean:.1f} \u00b1 {std:.1f} % there at {at_steps / 1e6:.1f}M"
        )
        about = f"{task} / {counted(int(n), 'robot')}"
        found.append(
            _weighed(text, best.mean, mean, std + best.std, ("own_mass", about), " against the better of them")
        )
    return found


def _weighed(
    text: str, ranged: float, alone: float, spread: float, where: tuple[str, str], against: str = ""
) -> Finding:
    """A design check's finding (its key and what it is about: `where`): `text`, then what training over the range
    costs (or gains) against the one-mass policy, in S.R. points, and whether that is within the seeds' `spread`."""
    gap = alone - ranged
    verdict = "within the seeds' spread" if gap <= spread else f"beyond the seeds' spread ({spread:.1f})"
    text += f": the range {'costs' if gap > 0 else 'gains'} {abs(gap):.1f} points{against}, {verdict}"
    numbers = {"range_points": ranged, "one_mass_points": alone, "gap_points": gap, "spread_points": spread}
    return Finding(text, gap <= spread, numbers, key=where[0], about=where[1])


def _rules(result: JobResult) -> str:
    """The rules a job trained under; a job made before jobs recorded them trained under mapush's, now `strict`."""
    return result.rules or "strict"


def _one_mass_references(
    results: list[JobResult], variant: str, task: str, robots: int, rules: set[str]
) -> list[JobResult]:
    """Other tables' jobs of `task` with `robots` whose mid level trained at the object's own mass, under the study's
    `rules`, and carries its own curve, made as their experiment plans now; one per mid-level run (a job another
    sweep took counts once). A mid level trained under other rules learned other pushes: no reference."""
    picked = {}
    for r in matching(results, variant=variant, task=task, num_agents=robots):
        if r.table == "team" or "mid" not in (r.stage_curves or {}) or curve_findings.curve_made_otherwise(r, "mid"):
            continue
        if _rules(r) not in rules:
            continue
        if r.sets_mass():  # trained at another mass
            continue
        picked.setdefault(r.stages.get("mid") or r.job_dir, r)
    return list(picked.values())


def _made_as(results: list[JobResult], mine: list[JobResult]) -> list[JobResult]:
    """The team jobs trained at one evaluated mass alone and made as the study's own jobs, the mass apart (same
    budget, same other overrides): the study's design check."""
    made = {(r.budget, r.made_besides_mass()) for r in mine}
    return [
        r
        for r in results
        if r.table == "team" and r.trained_mass_kg() is not None and (r.budget, r.made_besides_mass()) in made
    ]


def _fixed_mass_findings(
    alone_rows: list, ranged_rows: list, masses: dict[str, float | None], range_text: str
) -> list[Finding]:
    """The study's design checked directly where a sweep trained the same robots at one of the evaluated masses
    alone (`mapush sweep experiment=team agents=1 task.object.mass_range=null task.object.mass=8.0`): the same
    budget and the same evaluation at that mass, the range's policy against the one-mass policy (`team_table`'s
    rows of each, cell by cell)."""
    found = []
    for ((task, n), cells), (_, alone) in zip(ranged_rows, alone_rows, strict=True):
        for ranged, one, (name, mass) in zip(cells, alone, masses.items(), strict=True):
            if not one.values or not ranged.values:
                continue
            text = (
                f"{task} / {counted(int(n), 'robot')} at {_kg(name, mass)}: trained over {range_text}, "
                f"{ranged.mean:.1f} \u00b1 {ranged.std:.1f} %; trained at {_kg(name, mass)} alone "
                f"({counted(len(one.values), 'seed')}), {one.mean:.1f} \u00b1 {one.std:.1f} %"
            )
            about = f"{task} / {counted(int(n), 'robot')} at {_kg(name, mass)}"
            found.append(_weighed(text, ranged.mean, one.mean, one.std + ranged.std, ("mass_alone", about)))
    return found
