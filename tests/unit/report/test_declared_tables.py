"""A table declared in one YAML file (`mapush/report/declared.py`): a toy declaration over jobs made here by hand,
its claim judged on known numbers; malformed declarations refused in one line."""

from __future__ import annotations

import pytest

from mapush.errors import BadInput
from mapush.experiments.results import Change, JobResult
from mapush.report import declared
from mapush.report.formats import Cell, markdown, sidecar

TOY = """\
name: toy
title: Toy
row_header: [Method]
jobs: {table: main}
rows:
  - {id: sa, label: SA, match: {method: sa}}
  - {id: ours, label: Ours, match: {method: ours}}
columns:
  - {id: sr, label: "S.R. (%)", eval: main, metric: success_rate, scale: 100, paper: {ours: [77.5, 3.0]}}
note: A toy.
claims:
  - claim: Ours beats SA
    compare: {left: {row: ours, column: sr}, op: ">", right: {row: sa, column: sr}}
  - claim: SA stays under 25 %
    compare: {left: {row: sa, column: sr}, op: "<", right: 25}
"""


def job(method: str, seed: int, rate: float, table: str = "main") -> JobResult:
    return JobResult(table=table, variant="quick", method=method, task="cuboid", seed=seed,
                     evals={"main": {"success_rate": rate}}, job_dir=f"{method}{seed}")  # fmt: skip


def toy(tmp_path, text: str = TOY):
    path = tmp_path / "toy.yaml"
    path.write_text(text)
    return declared.builders(tmp_path)["toy"]


def claims(table) -> dict:
    return {f.claim: f for f in table.findings}


def test_a_declared_claim_holds_with_the_numbers_it_compares(tmp_path):
    made = [job("ours", 0, 0.8), job("ours", 1, 0.6), job("sa", 0, 0.1), job("sa", 1, 0.3), job("ours", 0, 0.0, "x")]
    table = toy(tmp_path)(made, "quick")
    assert table.name == "toy_quick" and table.columns == ["S.R. (%)"] and not table.missing
    assert [(labels, cells[0].mean) for labels, cells in table.rows] == [(["SA"], 20.0), (["Ours"], 70.0)]
    assert table.rows[1][1][0].sources == ["ours0", "ours1"]  # not the other table's job
    beats, under = claims(table)["Ours beats SA"], claims(table)["SA stays under 25 %"]
    assert (beats.holds, beats.op, beats.numbers) == (True, ">", {"left": 70.0, "right": 20.0})
    assert (under.holds, under.numbers) == (True, {"left": 20.0, "right": 25.0})
    assert sidecar(table)["findings"][0]["claim"] == "Ours beats SA"
    assert "(77.5 \u00b1 3.0)" in markdown(table)


def test_a_declared_claim_that_does_not_hold(tmp_path):
    made = [job("ours", 0, 0.2), job("sa", 0, 0.5), job("sa", 1, 0.3)]
    table = toy(tmp_path)(made, "quick")
    beats, under = claims(table)["Ours beats SA"], claims(table)["SA stays under 25 %"]
    assert (beats.holds, beats.numbers) == (False, {"left": 20.0, "right": 40.0})
    assert (under.holds, under.numbers) == (False, {"left": 40.0, "right": 25.0})


def test_a_claim_on_an_empty_cell_is_not_measured(tmp_path):
    table = toy(tmp_path)([job("sa", 0, 0.1)], "quick")
    beats = claims(table)["Ours beats SA"]
    assert (beats.holds, beats.numbers) == (None, {"right": 10.0})
    assert table.missing == ["Ours: no finished job: S.R. (%)"]
    assert claims(toy(tmp_path)([job("sa", 0, 0.1)], "long")).get("SA stays under 25 %").holds is None


def test_every_shipped_declaration_loads_and_is_a_table_of_mapush_tables():
    from mapush.report.tables import BUILDERS

    names = {declared.load(path)["name"] for path in declared.FOLDER.glob("*.yaml")}
    assert names and names <= set(BUILDERS)


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        (
            "note: A toy.",
            "notes: A toy.",
            "unknown key 'notes'; valid: claims, column_noun, columns, curves, eval_labels",
        ),
        ("paper: {ours: [77.5, 3.0]}", "paper: main.success_rate.cubiod", "not in paper.yaml: no 'cubiod'; valid: cub"),
        ("right: {row: sa, column: sr}}", "right: {row: sa, column: sr}, spread: noise}", "'noise'; valid: beyond"),
        (
            "right: {row: sa, column: sr}}",
            "right: {row: sa, column: sr}, among: [sa]}",
            "'among' is for op highest, lowest only, not '>'",
        ),
        ('op: ">", right: {row: sa, column: sr}', "op: highest, among: [sa]", "among ['sa'] is not a list of two or"),
        ('op: ">", right: {row: sa, column: sr}', "op: highest, among: sa", "among 'sa' is not a list of two or more"),
        ('op: ">", right: {row: sa, column: sr}', "op: highest, among: [sa, sa]", "is not a list of two or more"),
        ('op: ">", right: {row: sa, column: sr}', "op: highest, among: [sa, ours], spread: beyond", "'spread' is"),
        ("right: 25", "right: true", "right: expected a mapping"),
        ("right: 25", "right: {paper: 5}", "paper 5 is not a path; valid: a dotted path into paper.yaml"),
        ("  - claim: SA stays under 25 %", "  - claim: SA stays under 25 %\n    key: null", "key None is not text"),
        ("claim: SA stays under 25 %", "claim: Ours beats SA", "key 'Ours beats SA' about '' names two claims"),
        ("  - claim: SA stays under 25 %", "  - claim: SA stays under 25 %\n    key: budget", "is the budget checks'"),
        ('label: "S.R. (%)"', 'label: "S.R. {x}"', "column 'sr' label: unknown field 'x'; valid: ['reach_pct'"),
        ("{id: ours, label: Ours", "{id: sa, label: Ours", "row: id 'sa' is taken; valid: a new string"),
        ("note: A toy.", "readings: 5", "readings 5 is not a list; valid: a list"),
        ("right: 25", "right: {paper: main.success_rate.cubiod.sa}", "not in paper.yaml: no 'cubiod'; valid: cuboid"),
        ("right: 25", "right: {paper: main.tasks}", "is not a number of the paper's; valid: a number or [mean, std]"),
        ("note: A toy.", "readings: [ct]", "reading: unknown 'ct'; valid: sr"),
        ('op: ">"', 'op: "beats"', "unknown 'beats'; valid: >, <, >=, <="),
        ("eval: main,", "eval: mian,", "column 'sr' eval: unknown 'mian'; valid: "),
        ("metric: success_rate", "metric: succes", "unknown 'succes'; valid: success_rate, completion_time"),
        ("{method: sa}", "{methd: sa}", "unknown key 'methd'; valid: budget, experiment, lowlevel, method"),
        ("right: 25", "right: {row: sa, column: ct}", "right column: unknown 'ct'; valid: sr"),
        (
            "  - claim: SA stays under 25 %",
            "  - claim: SA stays under 25 %\n    along: columns",
            "left (along columns: a row only): unknown key 'column'; valid: row",
        ),
        (
            "  - claim: SA stays under 25 %",
            "  - claim: SA stays under 25 %\n    along: rows",
            "along: unknown 'rows'; valid: columns",
        ),
        ("match: {method: sa}}", "match: {method: sa}, evals: {main: nope}}", "evals (its own): unknown 'nope'"),
        ("match: {method: sa}}", "match: {method: sa}, evals: {nope: main}}", "evals (a column's): unknown 'nope'"),
        ("note: A toy.", "readings: [{metric: curve_end, label: x}]", "reading metric: unknown 'curve_end'; valid: "),
        ("note: A toy.", "readings: [{metric: falls}]", "reading: missing key 'label'"),
        ("note: A toy.", "panels: {P: [nobody]}", "panel 'P' row: unknown 'nobody'; valid: sa, ours"),
        ("{id: sa, label: SA, match: {method: sa}}", "{each: robots, id: a, label: A}", "row each: unknown 'robots'"),
        (
            "{id: sa, label: SA, match: {method: sa}}",
            "{each: agents, id: a, label: A}",
            "no experiment of table 'main' sweeps 'agents'",
        ),
        ("{id: sa, label: SA, match: {method: sa}}", "{each: task, id: 'a{n}', label: A}", "unknown field 'n'"),
        (
            "{id: sa, label: SA, match: {method: sa}}",
            "{each: task, id: a, label: A, match: [1]}",
            "row 'a' match: expected a mapping",
        ),
        (
            "{id: sa, label: SA, match: {method: sa}}",
            "{each: task, id: a, label: A, match: {task: cuboid}}",
            "match sets 'task', the field `each` fills",
        ),
        ("{id: sa, label: SA, match: {method: sa}}", "{each: task, id: 'a{value!x}', label: A}", "is no template"),
        ("{id: sa, label: SA", "{id: [sa], label: SA", "row: id ['sa'] is not text; valid: a new string"),
        ("note: A toy.", "readings: [{metric: falls, label: [x]}]", "reading 'falls': label ['x'] is not text"),
        ("note: A toy.", "readings: [{metric: falls, label: F}, {metric: falls, label: G}]", "'falls': is read twice"),
        (
            "  - claim: SA stays under 25 %",
            "  - claim: SA stays under 25 %\n    key: falls",
            "key 'falls' about '' is a reading's",
        ),
    ],
)
def test_a_malformed_declaration_is_refused_in_one_line_naming_the_choices(tmp_path, old, new, said):
    assert old in TOY
    given = TOY.replace(old, new, 1)
    if "key: falls" in new:  # a claim may not take the key of a reading's findings
        given = given.replace("note: A toy.", "readings: [{metric: falls, label: Falls}]")
    with pytest.raises(BadInput) as refused:
        toy(tmp_path, given)
    assert said in str(refused.value) and "\n" not in str(refused.value)
    assert str(refused.value).startswith("toy.yaml")


def test_a_claim_beyond_the_spread_holds_fails_or_lies_within_it(tmp_path):
    spread = TOY.replace("right: {row: sa, column: sr}}", "right: {row: sa, column: sr}, spread: beyond}")
    build = toy(tmp_path, spread)

    def beats(ours: tuple[float, float], sa: tuple[float, float]):
        made = [job("ours", s, r) for s, r in enumerate(ours)] + [job("sa", s, r) for s, r in enumerate(sa)]
        return build(made, "quick").finding("Ours beats SA")

    # 70 +- 10 against 20 +- 10: 50 points apart, the spread hypot(10, 10) = 14.1
    clear = beats((0.8, 0.6), (0.1, 0.3))
    assert clear.holds is True and clear.numbers == pytest.approx({"left": 70.0, "right": 20.0, "spread": 14.142},
                                                                  abs=1e-3)  # fmt: skip
    assert beats((0.3, 0.5), (0.2, 0.4)).holds is None  # 40 against 30: 10 points, within 14.1
    assert beats((0.2, 0.4), (0.3, 0.5)).holds is False  # not above at all


def test_a_highest_claim_holds_only_for_a_strict_highest_and_names_every_row_s_mean(tmp_path):
    highest = TOY.replace('op: ">", right: {row: sa, column: sr}', "op: highest, among: [sa, ours]")
    build = toy(tmp_path, highest)
    top = build([job("ours", 0, 0.8), job("sa", 0, 0.1)], "quick").finding("Ours beats SA")
    assert top.holds is True and top.numbers == pytest.approx({"Ours": 80.0, "SA": 10.0})
    assert build([job("ours", 0, 0.5), job("sa", 0, 0.5)], "quick").finding("Ours beats SA").holds is False  # a tie
    assert build([job("ours", 0, 0.5)], "quick").finding("Ours beats SA").holds is None  # nothing to be above


def test_a_claim_within_the_spread_fails_only_short_by_more_than_it_against_a_paper_number(tmp_path):
    # SA's cell against the paper's SA on the cuboid (4.5 %), at or above it, a shortfall within its std allowed
    within = TOY.replace(
        'op: "<", right: 25}', 'op: ">=", right: {paper: main.success_rate.cuboid.sa}, spread: within}'
    )
    build = toy(tmp_path, within)

    def at_least(rates):
        return build([job("sa", s, r) for s, r in enumerate(rates)], "quick").finding("SA stays under 25 %")

    assert at_least((0.04, 0.06)).numbers == pytest.approx({"left": 5.0, "right": 4.5, "spread": 1.0})
    assert at_least((0.04, 0.06)).holds is True
    assert at_least((0.02, 0.06)).holds is None  # 4.0 +- 2.0: short by 0.5, within its std
    assert at_least((0.01, 0.01)).holds is False  # 1.0 +- 0.0: short by 3.5


def test_a_claim_reading_a_cell_of_an_earlier_recipe_counts_it(tmp_path):
    made = [job("ours", 0, 0.8), job("sa", 0, 0.1)]
    made[0].made_otherwise = Change("stages", "its stages changed", ("mid",))
    table = toy(tmp_path)(made, "quick")
    assert table.finding("Ours beats SA").numbers["cells_made_otherwise"] == 1.0
    assert "cells_made_otherwise" not in table.finding("SA stays under 25 %").numbers


def test_a_claim_s_words_name_the_rows_it_compares_a_tie_and_a_one_seed_spread():
    from mapush.report.claims import Claim, Ref, judge

    rows = {r: {"label": [r], "name": r} for r in ("a", "b", "c")}
    columns = {"sr": {"label": "S.R.", "digits": 1}}

    def cells(**means):
        return {(r, "sr"): Cell(list(v)) for r, v in means.items()}

    highest = Claim("a is best", Ref("a", "sr"), "highest", among=("a", "b", "c"))
    tie = judge(highest, cells(a=[50.0], b=[50.0], c=[10.0]), rows, columns)
    assert (
        tie.holds is False
        and tie.text == "a is best: does not hold: a (50.0) ties with b (50.0), S.R. (means over seeds)"
    )
    top = judge(highest, cells(a=[60.0], b=[50.0], c=[10.0]), rows, columns)
    assert top.holds is True and top.names["other"] == "b"  # the next best, named in its words
    above = Claim("a above b", Ref("a", "sr"), ">", Ref("b", "sr"), spread="beyond")
    one_seed = judge(above, cells(a=[60.0], b=[50.0]), rows, columns)
    assert one_seed.holds is None and "spread" not in one_seed.numbers  # one seed: no spread to weigh
    equal = Claim("a as b", Ref("a", "sr"), ">=", Ref("b", "sr"), spread="beyond")
    assert judge(equal, cells(a=[50.0, 50.0], b=[50.0, 50.0]), rows, columns).holds is True  # spread 0, at it
    within = Claim("a above b", Ref("a", "sr"), ">", Ref("b", "sr"), spread="within")
    assert judge(within, cells(a=[50.0, 50.0], b=[50.0, 50.0]), rows, columns).holds is False  # spread 0: no slack


def test_a_row_template_makes_a_row_per_value_of_the_experiments_sweep_axis(tmp_path):
    from mapush.experiments.stage_plan import experiment_axis

    template = "  - {each: task, id: 'ours_{value}', label: 'Ours, {value}', match: {method: ours}}\n"
    text = TOY.replace("  - {id: ours,", template + "  - {id: ours,")
    cylinder = JobResult(table="main", variant="quick", method="ours", task="cylinder", seed=0,
                         evals={"main": {"success_rate": 0.25}}, job_dir="c")  # fmt: skip
    table = toy(tmp_path, text)([job("ours", 0, 0.5), cylinder], "quick")
    tasks = experiment_axis("main", "task")  # conf/experiment/main.yaml's sweep, in its order
    assert tasks == ["cuboid", "tblock", "cylinder"]
    assert [labels[0] for labels, _ in table.rows] == ["SA", *(f"Ours, {t}" for t in tasks), "Ours"]
    assert [cells[0].mean for _, cells in table.rows] == [None, 50.0, None, 25.0, 37.5]


def test_a_declared_table_lists_its_own_jobs_that_no_row_shows(tmp_path):
    own = TOY.replace("name: toy", "name: main").replace("  - {id: sa, label: SA, match: {method: sa}}\n", "")
    own = own[: own.index("claims:")]  # its claims read the row it drops
    (tmp_path / "own.yaml").write_text(own)
    table = declared.builders(tmp_path)["main"]([job("ours", 0, 0.8), job("sa", 0, 0.1)], "quick")
    assert "1 jobs in no row: sa0" in table.missing


def test_a_name_already_taken_is_refused(tmp_path):
    (tmp_path / "again.yaml").write_text(TOY)
    with pytest.raises(BadInput, match="'toy' is taken"):
        toy(tmp_path)
    (tmp_path / "again.yaml").unlink()
    (tmp_path / "toy.yaml").write_text(TOY.replace("name: toy", "name: main"))
    with pytest.raises(BadInput, match="'main' is taken"):
        declared.builders(tmp_path, taken=("main",))
