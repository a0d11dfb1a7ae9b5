"""Tables declared as data: a YAML file in `declared/` (or any folder) names a table's jobs, rows, columns and
claims, and `build` turns it and the jobs' results into a `Table` whose findings judge each claim. `mapush tables`
writes every declaration of `declared/` by its name (`builders`), beside the hand-written tables.

Its claims are `claims.py`'s: a cell against another, a number or the paper's, or the highest or lowest of a set
of rows, optionally weighing the seeds' spread.

A column reads one number of the jobs' evaluations (`METRICS`), the end of a stage's own learning curve
(`curve_end`, with `stage`), the share of episodes with a robot's fall (`falls`) or the env-steps the learning curves
took to reach their rate (`env_steps_to_reach`); its paper numbers may be read from `paper.yaml` by a dotted path
(`paper: ocb_ablation.success_rate.t20`, by row id). `curves` draws the rows' learning curves and judges each row's
budget, `readings` lists a column's cells under the table, or (`{metric, label}`) each row's number of an evaluation in
every column. A row may read its own evaluations in the columns' stead (`evals: {column's: row's}`): then it stands in
those columns only, and is not applicable (n/a) in the others. `panels` groups rows for the table's own figure.
"""

from __future__ import annotations

import functools
import string
from pathlib import Path

import yaml

from mapush.config import group_file, group_options
from mapush.errors import BadInput
from mapush.experiments.results import JobResult
from mapush.experiments.stage_plan import experiment_axis, experiment_evals
from mapush.report import curve_findings
from mapush.report.cells import PAPER, collect, fall_cell, final_cell, matching, reach_cell
from mapush.report.claims import checked_choice, checked_keys, judge, judge_along, parse
from mapush.report.formats import OVER_SEEDS, Cell, Finding, Table

FOLDER = Path(__file__).with_name("declared")
"""The shipped declarations, one table a file."""
KEYS = {"name", "title", "row_header", "jobs", "rows", "columns", "note", "claims", "curves", "readings",
        "eval_labels", "panels", "column_noun"}  # fmt: skip
ROW_KEYS = {"id", "label", "match", "name", "evals"}
EACH_KEYS = {"each", "id", "label", "name", "match"}
AXIS_FIELDS = {"agents": "num_agents", "task": "task", "method": "method"}
"""A row per value of a sweep axis (`each: agents`): the field of a job's result each axis fills."""
COLUMN_KEYS = {"id", "label", "eval", "metric", "scale", "digits", "paper", "stage"}
MATCH_KEYS = ["experiment", "table", "budget", "method", "method_label", "task", "num_agents", "seed", "rules",
              "lowlevel"]  # fmt: skip
"""The fields of a job (`JobResult`) a declaration may match; the variant is the table's own."""
REACH, CURVE_END, FALLS = "env_steps_to_reach", "curve_end", "falls"
"""Columns that read no one number of an evaluation: env-steps (M) to the learning curve's rate (its label may say
`{reach_pct}` and `{curve_eval}`: the rate in % and the curve's evaluation, by `eval_labels`); the last point of a
stage's own learning curve (`stage`); the share of an evaluation's episodes with a robot's fall (`cells.fall_cell`)."""
TYPES = {"name": str, "title": str, "row_header": list, "jobs": dict, "rows": list, "columns": list, "note": str,
         "claims": list, "curves": str, "readings": list, "eval_labels": dict, "panels": dict,
         "column_noun": str}  # fmt: skip
"""What each of a declaration's keys holds."""
KIND_WORDS = {str: "text", list: "a list", dict: "a mapping"}
LABEL_FIELDS = ["reach_pct", "curve_eval"]
"""What a column's label or the curves' title may say in braces (`_label_words`)."""
RESERVED = {"budget": "the budget checks", "reading": "the readings"}
"""Finding keys of a declared table's own that no claim may take."""
METRICS = ["success_rate", "completion_time", "completion_time_s", "path_length_m", FALLS, CURVE_END, REACH]
"""What a column may read."""
ROW_READING_KEYS = {"metric", "label"}
"""A reading of each row in every column (`readings: [{metric: falls, label: ...}]`): an evaluation's number."""


def load(path: Path) -> dict:
    """The declaration at `path`, checked: a one-line BadInput names any unknown key, claim kind, evaluation,
    metric, row, column or paper number, with the valid choices."""
    where = Path(path).name
    decl = checked_keys(where, yaml.safe_load(Path(path).read_text()), KEYS, {"name", "title", "rows", "columns"})
    decl = {"row_header": ["Row"], "jobs": {}, "note": "", "claims": [], "curves": "", "readings": [],
            "eval_labels": {}, "panels": {}, "column_noun": "column", **decl}  # fmt: skip
    for key, kind in TYPES.items():
        if not isinstance(decl[key], kind):
            raise BadInput(f"{where}: {key} {decl[key]!r} is not {KIND_WORDS[kind]}; valid: {KIND_WORDS[kind]}")
    checked_keys(f"{where} jobs", decl["jobs"], set(MATCH_KEYS))
    rows, columns = {}, {}
    for row in [r for given in decl["rows"] for r in _each(where, given, decl["jobs"].get("table"))]:  # templates
        checked_keys(f"{where} row", row, ROW_KEYS, {"id", "match"})
        _new_id(f"{where} row", row["id"], rows)
        checked_keys(f"{where} row {row['id']!r} match", row["match"], set(MATCH_KEYS))
        label = row.get("label")
        label = _method_label(f"{where} row {row['id']!r}", row["match"]) if label is None else label
        label = label if isinstance(label, list) else [label]
        if len(label) != len(decl["row_header"]):
            raise BadInput(f"{where} row {row['id']!r}: {len(label)} labels for row_header {decl['row_header']}")
        label = [str(x) for x in label]
        rows[row["id"]] = {**row, "label": label, "name": str(" / ".join(label) if row.get("name") is None
                                                            else row["name"])}  # fmt: skip
    evals = experiment_evals(decl["jobs"].get("table"))
    for row in rows.values():
        if "evals" in row:  # the row's own evaluations in the columns' stead
            mine = experiment_evals(row["match"].get("table", decl["jobs"].get("table")))
            if not isinstance(row["evals"], dict):
                raise BadInput(f"{where} row {row['id']!r}: evals {row['evals']!r} is not a mapping; valid: a mapping")
            for column_eval, own in row["evals"].items():
                checked_choice(f"{where} row {row['id']!r} evals (a column's)", column_eval, evals)
                checked_choice(f"{where} row {row['id']!r} evals (its own)", own, mine)
    for column in decl["columns"]:
        checked_keys(f"{where} column", column, COLUMN_KEYS, {"id", "label", "metric"})
        name = _new_id(f"{where} column", column["id"], columns)
        _fields(f"{where} column {name!r} label", column["label"])
        checked_choice(f"{where} column {name!r} metric", column["metric"], METRICS)
        if column["metric"] != REACH and column["metric"] != CURVE_END:
            checked_choice(f"{where} column {name!r} eval", column.get("eval"), evals)
        if column["metric"] == CURVE_END:
            checked_choice(f"{where} column {name!r} stage", column.get("stage"), group_options("level"))
        paper = _paper(f"{where} column {name!r} paper", column.get("paper") or {})
        for row in paper:
            checked_choice(f"{where} column {name!r} paper row", row, list(rows))
        columns[name] = {"scale": 1.0, "digits": 1, **column, "paper": paper}
    reserved = dict(RESERVED)
    for name in decl["readings"]:
        if isinstance(name, dict):
            reading = checked_keys(f"{where} reading", name, ROW_READING_KEYS, ROW_READING_KEYS)
            checked_choice(f"{where} reading metric", reading["metric"], [m for m in METRICS if m not in
                                                                          (REACH, CURVE_END)])  # fmt: skip
            if not isinstance(reading["label"], str) or reading["metric"] in reserved:
                why = "is read twice" if reading["metric"] in reserved else f"label {reading['label']!r} is not text"
                raise BadInput(
                    f"{where} reading {reading['metric']!r}: {why}; valid: one reading a metric, a text label"
                )
            reserved[reading["metric"]] = "a reading"
        else:
            checked_choice(f"{where} reading", name, list(columns))
    for title, members in decl["panels"].items():
        if not isinstance(members, list):
            raise BadInput(f"{where} panel {title!r}: {members!r} is not a list of rows; valid: rows of {list(rows)}")
        for row in members:
            checked_choice(f"{where} panel {title!r} row", row, list(rows))
    _fields(f"{where} curves", decl["curves"])
    claims = [parse(f"{where} claim", c, rows, columns, _paper) for c in decl["claims"]]
    named = [(c.key, c.about) for c in claims]
    for key, about in named:
        if key in reserved or named.count((key, about)) > 1:
            why = f"is {reserved[key]}'s" if key in reserved else "names two claims"
            raise BadInput(f"{where} claim: key {key!r} about {about!r} {why}; give each claim its own key or about")
    return {**decl, "rows": rows, "columns": columns, "claims": claims}


def _each(where: str, row, table: str | None) -> list:
    """A row as given, or a template's rows: `each: AXIS` makes one per value of that sweep axis of the table's
    experiments, its `id`, `label` and `name` formatted with the value (`{value}`, and `{s}`: "s" unless it is 1)."""
    if not isinstance(row, dict) or "each" not in row:
        return [row]
    checked_keys(f"{where} row", row, EACH_KEYS, {"each", "id", "label"})
    checked_choice(f"{where} row each", row["each"], list(AXIS_FIELDS))
    match = checked_keys(f"{where} row {row['id']!r} match", row.get("match") or {}, set(MATCH_KEYS))
    if AXIS_FIELDS[row["each"]] in match:
        raise BadInput(f"{where} row {row['id']!r}: match sets {AXIS_FIELDS[row['each']]!r}, the field `each` fills; "
                       "valid: one of the two")  # fmt: skip
    table = match.get("table", table)  # the row's own jobs' table, as its `evals` take it
    values = experiment_axis(table, row["each"])
    if not values:
        raise BadInput(f"{where} row each: no experiment of table {table!r} sweeps {row['each']!r}; valid: an axis "
                       "its experiments sweep")  # fmt: skip

    def filled(text, value):
        if isinstance(text, list):
            return [filled(part, value) for part in text]
        _fields(f"{where} row {row['id']!r}", text, ["value", "s"])
        try:
            return str(text).format(value=value, s="" if value == 1 else "s")
        except (ValueError, TypeError) as err:  # a conversion or format spec the value does not take
            raise BadInput(f"{where} row {row['id']!r}: {text!r} is no template ({err}); valid: text with "
                           "{value} and {s}") from None  # fmt: skip

    return [{**{key: filled(row[key], value) for key in ("id", "label", "name") if key in row},
             "match": {**match, AXIS_FIELDS[row["each"]]: value}} for value in values]  # fmt: skip


def _new_id(where: str, given, taken: dict) -> str:
    """A row's or column's id: a string no other row or column of its kind has."""
    if not isinstance(given, str) or given in taken:
        why = "not text" if not isinstance(given, str) else "taken"
        raise BadInput(f"{where}: id {given!r} is {why}; valid: a new string")
    return given


def _fields(where: str, text, valid: list[str] = LABEL_FIELDS) -> None:
    """A label or title that `build` formats: text whose `{...}` fields are `valid` (`LABEL_FIELDS`)."""
    try:
        names = {field for _, field, _, _ in string.Formatter().parse(str(text)) if field is not None}
    except ValueError as err:
        raise BadInput(f"{where}: {text!r} is no label ({err}); valid: text with fields {valid}") from None
    if names - set(valid):
        raise BadInput(f"{where}: unknown field {sorted(names - set(valid))[0]!r}; valid: {valid}")


def _method_label(where: str, match: dict) -> str:
    """A row's label where its declaration gives none: the label of the method it matches (`conf/method/`)."""
    if "method" not in match:
        raise BadInput(f"{where}: missing key 'label' (a row matching no method has no label of its own)")
    return str(group_file("method", match["method"]).label)


def _paper(where: str, given) -> dict:
    """A column's paper numbers by row id: given as they are, or a dotted path into `paper.yaml`."""
    if not isinstance(given, str):
        return given
    found = PAPER
    for part in given.split("."):
        if not isinstance(found, dict) or part not in found:
            valid = ", ".join(found) if isinstance(found, dict) else "none"
            raise BadInput(f"{where}: {given!r} is not in paper.yaml: no {part!r}; valid: {valid}")
        found = found[part]
    return found


def build(decl: dict, results: list[JobResult], variant: str) -> Table:
    """The declared table of `variant`: a cell per row and column from the jobs that match both, its claims
    judged on their means."""
    jobs = matching(results, **decl["jobs"], variant=variant)
    lines = {row["name"]: matching(jobs, **row["match"]) for row in decl["rows"].values()}
    words = _label_words(decl, jobs)
    cells: dict[tuple[str, str], Cell] = {}
    missing = []
    for row_id, row in decl["rows"].items():
        lacking: dict[str, list[str]] = {}  # what a row's empty cells lack, and in which columns
        for col_id, col in decl["columns"].items():
            cell, lack = _cell(jobs, row, col)
            cell.digits = int(col["digits"])
            paper = col["paper"].get(row_id)
            cell.paper = tuple(float(x) for x in paper) if paper else None
            if not cell.values and not cell.unreached and cell.applicable:
                lacking.setdefault(lack, []).append(col["label"].format(**words))
            cells[row_id, col_id] = cell
        missing += [f"{row['name']}: {lack}: {', '.join(columns)}" for lack, columns in lacking.items()]
    if decl["jobs"].get("table") == decl["name"]:  # the table's own jobs that no row shows
        unrowed = [Path(r.job_dir).name for r in jobs if not any(matching([r], **row["match"])
                                                                 for row in decl["rows"].values())]  # fmt: skip
        if unrowed:
            missing.append(
                f"{len(unrowed)} jobs in no row: {', '.join(sorted(unrowed)[:3])}"
                + (", ..." if len(unrowed) > 3 else "")
            )
    rows = [(row["label"], [cells[row_id, c] for c in decl["columns"]]) for row_id, row in decl["rows"].items()]
    findings = [judge_along(claim, cells, decl["rows"], decl["columns"], decl["column_noun"]) if claim.along else
                judge(claim, cells, decl["rows"], decl["columns"]) for claim in decl["claims"]]  # fmt: skip
    for name in decl["readings"]:
        findings += _row_readings(decl, name, jobs) if isinstance(name, dict) else [_reading(decl, name, cells, words)]
    curves = {decl["curves"].format(**words): lines} if decl["curves"] else {}
    if curves:
        findings += curve_findings.budget_findings(lines, curve_findings.drawn_stages(jobs))  # and earlier stages'
    paper = any(col["paper"] for col in decl["columns"].values())
    return Table(
        f"{decl['name']}_{variant}",
        f"{decl['title']} ({variant})",
        list(decl["row_header"]),
        [col["label"].format(**words) for col in decl["columns"].values()],
        rows,
        missing,
        " ".join(filter(None, [decl["note"], f"Each cell: {OVER_SEEDS}."])),
        findings,
        curves,
        reading="ours (paper)" if paper else "",
        panels={title: [decl["rows"][row]["label"] for row in members] for title, members in decl["panels"].items()},
        also_behind=[r for r in jobs if r.table != decl["name"] and any(matching([r], **row["match"])
                                                                        for row in decl["rows"].values())],
    )  # fmt: skip


def _cell(jobs: list[JobResult], row: dict, col: dict) -> tuple[Cell, str]:
    """The cell of a row's jobs in a column, and what it lacks where it is empty; not applicable where the row reads
    its own evaluations and none stands for the column's."""
    match = row["match"]
    if "evals" in row and col.get("eval") is not None:
        if col["eval"] not in row["evals"]:
            return Cell(applicable=False), ""
        col = {**col, "eval": row["evals"][col["eval"]]}
    if col["metric"] == REACH:
        return reach_cell(matching(jobs, **match)), "no learning curve"
    if col["metric"] == CURVE_END:
        return final_cell(jobs, col["stage"], float(col["scale"]), **match), f"no curve of the {col['stage']} level"
    lack = "no finished evaluation" if matching(jobs, **match) else "no finished job"  # jobs, but not this one's
    if col["metric"] == FALLS:
        return fall_cell(jobs, **match, eval=col["eval"]), lack
    return collect(jobs, col["metric"], float(col["scale"]), **match, eval=col["eval"]), lack


def _label_words(decl: dict, jobs: list[JobResult]) -> dict[str, str]:
    """What a label's `{reach_pct}` and `{curve_eval}` say: the learning curves' rate and evaluation."""
    curve = next((r.curve for r in jobs if r.curve), None)
    if curve is None:
        return {"reach_pct": "its", "curve_eval": "its evaluation"}
    return {
        "reach_pct": f"{100 * float(curve.reach):.0f} %",
        "curve_eval": decl["eval_labels"].get(curve.eval, curve.eval),
    }


def _reading(decl: dict, name: str, cells: dict, words: dict) -> Finding:
    """A column's cells read out under the table, claiming nothing."""
    label = decl["columns"][name]["label"].format(**words)
    parts = [(row["name"], cells[row_id, name]) for row_id, row in decl["rows"].items()]
    numbers = {row: cell.mean for row, cell in parts if cell.values}
    return Finding(f"{label}: {'; '.join(f'{row} {cell.text()}' for row, cell in parts)}", None, numbers,
                   key="reading", about=label)  # fmt: skip


def _row_readings(decl: dict, reading: dict, jobs: list[JobResult]) -> list[Finding]:
    """Each row's number of `reading["metric"]` in every column it stands in (its evaluation there; columns of one
    evaluation once, by the first's label, at its scale), under the table; a row with none is left out."""
    found = []
    by_eval = {}
    for col in decl["columns"].values():
        if col.get("eval") is not None:
            by_eval.setdefault(col["eval"], col)
    for row in decl["rows"].values():
        cells = {col["label"]: _cell(jobs, row, {**col, "metric": reading["metric"]})[0] for col in by_eval.values()}
        shown = {label: cell for label, cell in cells.items() if cell.applicable}
        if any(cell.values for cell in shown.values()):
            text = f"{reading['label']}, {row['name']}: " + ", ".join(f"{k} {c.text()}" for k, c in shown.items())
            numbers = {label: cell.mean for label, cell in shown.items() if cell.values}
            found.append(Finding(text, numbers=numbers, key=reading["metric"], about=row["name"]))
    return found


def builders(folder: Path = FOLDER, taken: tuple[str, ...] = ()) -> dict:
    """A builder `(results, variant) -> Table` for each declaration in `folder`, by its name; a name in `taken`
    (a hand-written table's) or given twice is refused."""
    found = {}
    for path in sorted(Path(folder).glob("*.yaml")):
        decl = load(path)
        if decl["name"] in found or decl["name"] in taken:
            raise BadInput(f"{path.name}: table name {decl['name']!r} is taken; taken: {', '.join([*taken, *found])}")
        found[decl["name"]] = functools.partial(build, decl)
    return found
