"""Tables declared as data: a YAML file in `declared/` (or any folder) names a table's jobs, rows, columns and
claims, and `build` turns it and the jobs' results into a `Table` whose findings judge each claim. `mapush tables`
writes every declaration of `declared/` by its name (`builders`), beside the hand-written tables.

A claim compares one cell's mean over seeds with another's or with a number (`OPS`); its finding holds True or
False, or None where a cell it reads has no finished job. `claim_sentence` is the one place its words are made.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from dataclasses import dataclass
from pathlib import Path

import yaml

from mapush.errors import BadInput
from mapush.experiments.results import JobResult
from mapush.experiments.stage_plan import experiment_evals
from mapush.report.cells import collect, matching
from mapush.report.formats import OVER_SEEDS, Cell, Finding, Table

FOLDER = Path(__file__).with_name("declared")
"""The shipped declarations, one table a file."""
KEYS = {"name", "title", "row_header", "jobs", "rows", "columns", "note", "claims"}
ROW_KEYS = {"id", "label", "match"}
COLUMN_KEYS = {"id", "label", "eval", "metric", "scale", "digits", "paper"}
CLAIM_KEYS = {"claim", "compare"}
COMPARE_KEYS = {"left", "op", "right"}
REF_KEYS = {"row", "column"}
MATCH_KEYS = ["experiment", "table", "budget", "method", "method_label", "task", "num_agents", "seed", "rules",
              "lowlevel"]  # fmt: skip
"""The fields of a job (`JobResult`) a declaration may match; the variant is the table's own."""
METRICS = ["success_rate", "completion_time", "completion_time_s", "path_length_m"]
"""The numbers of an evaluation's record a column may read."""
OPS = {">": (operator.gt, "above"), "<": (operator.lt, "below"), ">=": (operator.ge, "at or above"),
       "<=": (operator.le, "at or below")}  # fmt: skip
"""The kinds of claim: a cell above or below another cell or a number (means over seeds)."""


@dataclass(frozen=True)
class Ref:
    row: str
    column: str


@dataclass(frozen=True)
class Claim:
    text: str
    left: Ref
    op: str
    right: Ref | float


def _keys(where: str, given, known: set[str], required: set[str] = frozenset()) -> dict:
    """`given` as a mapping with only `known` keys and every `required` one, else a one-line BadInput."""
    if not isinstance(given, dict):
        raise BadInput(f"{where}: expected a mapping with keys {sorted(known)}, got {given!r}")
    unknown = sorted(set(given) - known)
    if unknown:
        raise BadInput(f"{where}: unknown key {unknown[0]!r}; valid: {', '.join(sorted(known))}")
    lacking = sorted(required - set(given))
    if lacking:
        raise BadInput(f"{where}: missing key {lacking[0]!r}; required: {', '.join(sorted(required))}")
    return given


def _choice(where: str, value, valid) -> None:
    if value not in valid:
        raise BadInput(f"{where}: unknown {value!r}; valid: {', '.join(str(v) for v in valid)}")


def load(path: Path) -> dict:
    """The declaration at `path`, checked: a one-line BadInput names any unknown key, claim kind, evaluation,
    metric, row or column, with the valid choices."""
    where = Path(path).name
    decl = _keys(where, yaml.safe_load(Path(path).read_text()), KEYS, {"name", "title", "rows", "columns"})
    decl = {"row_header": ["Row"], "jobs": {}, "note": "", "claims": [], **decl}
    _keys(f"{where} jobs", decl["jobs"], set(MATCH_KEYS))
    rows, columns = {}, {}
    for row in decl["rows"]:
        _keys(f"{where} row", row, ROW_KEYS, ROW_KEYS)
        _keys(f"{where} row {row['id']!r} match", row["match"], set(MATCH_KEYS))
        label = row["label"] if isinstance(row["label"], list) else [row["label"]]
        if len(label) != len(decl["row_header"]):
            raise BadInput(f"{where} row {row['id']!r}: {len(label)} labels for row_header {decl['row_header']}")
        rows[row["id"]] = {**row, "label": [str(x) for x in label]}
    evals = experiment_evals(decl["jobs"].get("table"))
    for column in decl["columns"]:
        _keys(f"{where} column", column, COLUMN_KEYS, {"id", "label", "eval", "metric"})
        name = column["id"]
        _choice(f"{where} column {name!r} eval", column["eval"], evals)
        _choice(f"{where} column {name!r} metric", column["metric"], METRICS)
        for row in column.get("paper") or {}:
            _choice(f"{where} column {name!r} paper row", row, list(rows))
        columns[name] = {"scale": 1.0, "digits": 1, "paper": {}, **column}
    claims = [_claim(f"{where} claim", c, rows, columns) for c in decl["claims"]]
    return {**decl, "rows": rows, "columns": columns, "claims": claims}


def _claim(where: str, given, rows: dict, columns: dict) -> Claim:
    given = _keys(where, given, CLAIM_KEYS, CLAIM_KEYS)
    where = f"{where} {given['claim']!r}"
    compare = _keys(where, given["compare"], COMPARE_KEYS, COMPARE_KEYS)
    _choice(f"{where} op (the claim's kind)", compare["op"], list(OPS))

    def ref(side: str, value):
        if isinstance(value, int | float) and side == "right":
            return float(value)
        value = _keys(f"{where} {side}", value, REF_KEYS, REF_KEYS)
        _choice(f"{where} {side} row", value["row"], list(rows))
        _choice(f"{where} {side} column", value["column"], list(columns))
        return Ref(value["row"], value["column"])

    return Claim(str(given["claim"]), ref("left", compare["left"]), compare["op"], ref("right", compare["right"]))


def build(decl: dict, results: list[JobResult], variant: str) -> Table:
    """The declared table of `variant`: a cell per row and column from the jobs that match both, its claims
    judged on their means."""
    jobs = matching(results, **decl["jobs"], variant=variant)
    cells: dict[tuple[str, str], Cell] = {}
    missing = []
    for row_id, row in decl["rows"].items():
        for col_id, col in decl["columns"].items():
            cell = collect(jobs, col["metric"], float(col["scale"]), **row["match"], eval=col["eval"])
            cell.digits = int(col["digits"])
            paper = col["paper"].get(row_id)
            cell.paper = tuple(float(x) for x in paper) if paper else None
            if not cell.values:
                missing.append(f"{' / '.join(row['label'])} / {col['label']}: no finished job")
            cells[row_id, col_id] = cell
    rows = [(row["label"], [cells[row_id, c] for c in decl["columns"]]) for row_id, row in decl["rows"].items()]
    findings = [judge(claim, cells, decl) for claim in decl["claims"]]
    paper = any(col["paper"] for col in decl["columns"].values())
    return Table(
        f"{decl['name']}_{variant}",
        f"{decl['title']} ({variant})",
        list(decl["row_header"]),
        [col["label"] for col in decl["columns"].values()],
        rows,
        missing,
        " ".join(filter(None, [decl["note"], f"Each cell: {OVER_SEEDS}."])),
        findings,
        reading="ours (paper)" if paper else "",
        also_behind=[r for r in jobs if any(matching([r], **row["match"]) for row in decl["rows"].values())],
    )


def judge(claim: Claim, cells: dict[tuple[str, str], Cell], decl: dict) -> Finding:
    """The claim's finding: True or False on the cells' means, None where a cell it reads is empty."""
    numbers, names = {}, {}
    for side, ref in (("left", claim.left), ("right", claim.right)):
        if isinstance(ref, float):
            numbers[side], names[side] = ref, ""
            continue
        names[side] = f"{' / '.join(decl['rows'][ref.row]['label'])}, {decl['columns'][ref.column]['label']}"
        if cells[ref.row, ref.column].values:
            numbers[side] = cells[ref.row, ref.column].mean
    holds = bool(OPS[claim.op][0](numbers["left"], numbers["right"])) if len(numbers) == 2 else None
    finding = Finding("", holds, numbers, claim=claim.text, op=claim.op, names=names, key=claim.text)
    return dataclasses.replace(finding, text=claim_sentence(finding))


def claim_sentence(finding: Finding) -> str:
    """A claim's finding in words: "Ours beats SA on the cuboid: does not hold: Cuboid / Ours, S.R. (%) 60.0 is
    not above Cuboid / SA, S.R. (%) 62.0 (means over seeds)"."""
    if finding.holds is None:
        unmeasured = [finding.names[side] for side in ("left", "right") if side not in finding.numbers]
        return f"{finding.claim}: not measured: no finished job for {'; '.join(unmeasured)}"
    left, right = (
        " ".join(filter(None, [finding.names[side], f"{finding.numbers[side]:.1f}"])) for side in ("left", "right")
    )
    verdict, negation = ("holds", "") if finding.holds else ("does not hold", "not ")
    return f"{finding.claim}: {verdict}: {left} is {negation}{OPS[finding.op][1]} {right} (means over seeds)"


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
