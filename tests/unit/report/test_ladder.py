"""The ladder table (`declared/ladder.yaml`): each paper finding judged rung by rung, from jobs' results made here by
hand (known numbers)."""

from __future__ import annotations

import pytest

from mapush.experiments.results import JobResult
from mapush.report import declared
from mapush.report.formats import NOT_APPLICABLE, keys

OBJECTS = ("cuboid", "tblock", "cylinder")
LADDER = declared.load(declared.FOLDER / "ladder.yaml")
RUNGS = [column["eval"] for column in LADDER["columns"].values()]


def ladder(results: list[JobResult]):
    return declared.build(LADDER, results, "quick")


def evals(rates: dict[str, float], fell: float = 0.1) -> dict:
    """An evaluation record per rung (eval name -> success rate), each with a fall share."""
    return {name: {"success_rate": sr, "events": {"falls": {"episode_share": fell, "per_episode": fell}}}
            for name, sr in rates.items()}  # fmt: skip


def job(table: str, method: str, task: str, seed: int, rates: dict[str, float], agents: int = 2) -> JobResult:
    return JobResult(
        table=table, variant="quick", method=method, task=task, num_agents=agents, seed=seed, evals=evals(rates),
        job_dir=f"{table}/{method},{task},{agents},{seed}",
    )  # fmt: skip


def every_rung(sr: float, **at: float) -> dict[str, float]:
    """`sr` on every rung, but the rungs named in `at`."""
    return {name: at.get(name, sr) for name in RUNGS}


def results(ours_cylinder_strict: float = 0.7, two_robots: tuple[float, float] = (0.5, 0.5)) -> list[JobResult]:
    """Ours 0.8 and SA 0.1 everywhere, but Ours on the cylinder at the `strict` rung and after it; the cylinder's
    robot counts 1: 0.1, 2: `two_robots` (by seed), 3: 0.8, 4: 0.7 on every rung; OCB 0.6 against 0.2 at 20 s."""
    made = []
    for seed in (0, 1):
        for task in OBJECTS:
            low = {"strict": ours_cylinder_strict, "old_tracker": ours_cylinder_strict} if task == "cylinder" else {}
            made.append(job("main", "ours", task, seed, every_rung(0.8, **low)))
            made.append(job("main", "sa", task, seed, every_rung(0.1), agents=1))
        for n, sr in ((1, 0.1), (2, two_robots[seed]), (3, 0.8), (4, 0.7)):
            made.append(job("scale", "ours", "cylinder", seed, every_rung(sr), agents=n))
        for method, sr in (("ours", 0.6), ("ours_no_ocb", 0.2)):
            ocb = {"t20": sr, "t20_strict": sr, "t20_old_tracker": sr}
            made.append(job("ocb_ablation", method, "ocb_cuboid", seed, ocb))
    return made


def test_every_row_and_rung_is_filled_from_its_jobs_evaluation():
    table = ladder(results())
    assert table.columns == [column["label"] for column in LADDER["columns"].values()]
    assert not table.missing
    cells = {tuple(labels): cells for labels, cells in table.rows}
    assert [c.mean for c in cells[("Cylinder", "Ours")]] == [80.0, 80.0, 80.0, 70.0, 70.0, 80.0]
    assert cells[("Cylinder", "3 robots")][0].values == [80.0, 80.0]


def test_the_ocb_rows_stand_on_the_rungs_their_own_evaluations_map_and_are_not_applicable_on_the_others():
    table = ladder(results())
    (ocb,) = [cells for labels, cells in table.rows if labels[1] == "Ours (mid level)"]
    assert [c.text() if not c.applicable else c.mean for c in ocb] == [
        NOT_APPLICABLE, 60.0, NOT_APPLICABLE, 60.0, 60.0, NOT_APPLICABLE]  # fmt: skip


def test_a_claim_names_the_first_rung_where_it_stops_holding():
    table = ladder(results(ours_cylinder_strict=0.5))
    ours = table.finding("ours_at_least", "Cylinder")
    assert ours.holds is False and ours.numbers["first_failing_rung"] == 3.0  # 3: strict, the cylinder at 50 %
    assert ours.numbers["left"] == 50.0 and ours.numbers["right"] == 60.0
    assert table.finding("ours_at_least", "Cuboid").holds is True


def test_claims_that_hold_on_every_rung_say_so():
    table = ladder(results())
    claims = ["sa_below", "ours_at_least", "team_above_one", "two_above_one", "three_best", "four_below_three",
              "ocb_gain"]  # fmt: skip
    assert list(dict.fromkeys(key for key, _ in keys(table.findings) if key != "falls")) == claims
    for key, about in keys(table.findings):
        if key != "falls":
            found = table.finding(key, about)
            assert found.holds is True and found.numbers == {"unmeasured_rungs": 0.0}, found.text


def test_a_difference_within_the_seeds_spread_leaves_a_well_above_claim_unsettled_not_failed():
    table = ladder(results(two_robots=(0.05, 0.45)))  # 2 robots 25 +- 20 against 1 robot 10 +- 0: within
    two = table.finding("two_above_one")
    assert two.holds is None and "first_failing_rung" not in two.numbers
    assert "within the seeds' spread at 0: orig. friction" in two.text


def test_a_claim_on_one_seed_is_not_judged_against_a_spread_nor_called_within_it():
    table = ladder([r for r in results() if r.seed == 0])
    two = table.finding("two_above_one")
    assert two.holds is None and "within the seeds' spread" not in two.text
    assert "not judged (a cell of one seed) at 0: orig. friction" in two.text


def test_a_failure_after_unmeasured_rungs_is_not_called_the_first():
    made = [r for r in results(ours_cylinder_strict=0.5)]
    for r in made:
        for name in ("original_friction", "main", "fall_ends"):
            r.evals.pop(name, None)
    ours = ladder(made).finding("ours_at_least", "Cylinder")
    assert ours.holds is False and ours.numbers["first_failing_rung"] == 3.0
    assert ours.numbers["unmeasured_before"] == 3.0 and "first stops holding" not in ours.text


def test_an_along_claim_counts_the_cells_of_an_earlier_recipe_it_read_on_every_rung():
    from mapush.experiments.results import Change

    made = results()
    for r in made:
        if r.table == "main" and r.task == "cuboid" and r.method == "sa":
            r.made_otherwise = Change(kind="stages", text="its stages changed", stages=("high",))
    sa = ladder(made).finding("sa_below", "Cuboid")
    assert sa.numbers["cells_made_otherwise"] == 6.0 and sa.text.endswith("(cells marked \u2020: an earlier recipe's)")


def test_a_rung_without_evaluations_is_named_not_measured_and_listed_missing():
    made = [r for r in results() if not (r.table == "scale" and r.num_agents == 4)]
    for r in made:
        r.evals.pop("fall_ends", None)
    table = ladder(made)
    assert table.finding("sa_below", "Cuboid").numbers["unmeasured_rungs"] == 1.0  # 2: fall ends
    assert table.finding("four_below_three").holds is None
    assert "Cylinder / 4 robots: no finished job: 0: orig. friction, 1: original, 2: fall ends" in table.missing[-1]
    assert "Cuboid / Ours: no finished evaluation: 2: fall ends" in table.missing
    # the OCB rows stand only where a mid-level push changes: the friction and legged rungs are not judged there
    assert table.finding("ocb_gain").numbers["unmeasured_rungs"] == 0.0  # nor the fall rung: a push has no fall rule


def test_the_fall_shares_come_from_the_evaluations_events():
    table = ladder(results())
    assert table.finding("falls", "Cuboid / Ours").numbers["1: original"] == 10.0
    assert (
        "0: orig. friction" not in table.finding("falls", "Free-space cuboid, 20 s pushes / Ours (mid level)").numbers
    )


def test_a_fall_cell_reads_the_events_count_and_before_events_the_share_a_fall_ended():
    from mapush.report.cells import events_finding, fall_cell

    events = {"falls": {"episode_share": 0.7}}
    counted_ = JobResult(method="ours", evals={"main": {"success_rate": 0.2, "events": events, "exceptions": {}}},
                         job_dir="a")  # fmt: skip
    before = JobResult(
        method="ours", evals={"main": {"success_rate": 0.2, "exceptions": {"robot_tilt": 0.3}}}, job_dir="b"
    )
    assert fall_cell([counted_, before], eval="main").values == [70.0, 30.0]
    (line,) = events_finding({"Ours": [counted_]}, "main", "Cuboid")  # events a record lacks are left out
    assert line.key == "events" and line.numbers == {"Ours falls": 70.0}


def test_a_tables_setup_line_counts_its_jobs_by_rules_and_low_level():
    from mapush.report.cells import setup_of

    line = setup_of([JobResult(rules="original", lowlevel="tracker")] * 3 + [JobResult()])
    assert line.startswith(
        "Trained under rules=original on lowlevel=tracker (3 jobs); rules=strict (1 job made before "
    )
    assert setup_of([JobResult(rules="strict", lowlevel="go1")]) == "Trained under rules=strict on lowlevel=go1 (1 job)"
    assert setup_of([]) == ""


def test_the_fall_split_reads_the_successes_without_a_fall_off_the_fall_ends_rung():
    from mapush.report.cells import fall_split, fall_split_finding

    def record(sr: float, fell: float) -> dict:
        return {"success_rate": sr, "events": {"falls": {"episode_share": fell}}}

    same = JobResult(evals={"main": record(0.6, 0.5), "fall_ends": record(0.4, 0.5)}, job_dir="a")
    # 40 % succeed with no fall, of the 50 % without one: 80 %; the other 20 % succeed of the 50 % with one: 40 %
    split, seeds = fall_split([same])
    assert seeds == 1 and split == pytest.approx({"fall_share": 50.0, "sr_without_fall": 80.0, "sr_with_fall": 40.0})
    other = JobResult(evals={"main": record(0.6, 0.5), "fall_ends": record(0.1, 0.7)}, job_dir="b")
    assert fall_split([same, other])[1] == 1  # another share of episodes fell: not the same episodes, left out
    never = JobResult(evals={"main": record(0.9, 0.0), "fall_ends": record(0.9, 0.0)}, job_dir="c")
    assert fall_split([never])[0] == pytest.approx({"fall_share": 0.0, "sr_without_fall": 90.0})
    (line,) = fall_split_finding({"Ours": [same]}, "Cylinder", 71.2)
    assert line.key == "fall_split" and line.numbers["Ours sr_without_fall"] == pytest.approx(80.0)
    assert fall_split_finding({"Ours": [JobResult(evals={"main": record(0.6, 0.5)}, job_dir="d")]}, "Cylinder") == []
