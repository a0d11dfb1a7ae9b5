"""Tables declared as data: a YAML file in `declared/` (or any folder) names a table's jobs, rows, columns and
claims, and `build` turns it and the jobs' results into a `Table` whose findings judge each claim. `mapush tables`
writes every declaration of `declared/` by its name (`builders`), beside the hand-written tables.

A claim compares one cell's mean over seeds with another's or with a number (`OPS`); its finding holds True or
False, or None where a cell it reads has no finished job. Weighed `beyond: spread`, it holds only where the two
cells differ by more than the seeds' spread (both stds in quadrature), fails where they do not differ the claimed
way at all, and is None between. `claim_sentence` is the one place its words are made.

A column may read the paper's numbers from `paper.yaml` (`paper: ocb_ablation.success_rate.t20`, by row id), or
the env-steps the learning curves took to reach their rate (`metric: env_steps_to_reach`); `curves` draws the rows'
learning curves and judges each row's budget, `readings` lists a column's cells under the table.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from mapush.config import group_file
from mapush.errors import BadInput
from mapush.experiments.results import JobResult
from mapush.experiments.stage_plan import experiment_evals
from mapush.report import curve_findings
from mapush.report.cells import PAPER, collect, matching, reach_cell
from mapush.report.formats import OVER_SEEDS, Cell, Finding, Table

FOLDER = Path(__file__).with_name("declared")
"""The shipped declarations, one table a file."""
KEYS = {"name", "title", "row_header", "jobs", "rows", "columns", "note", "claims", "curves", "readings",
        "eval_labels"}  # fmt: skip
ROW_KEYS = {"id", "label", "match"}
COLUMN_KEYS = {"id", "label", "eval", "metric", "scale", "digits", "paper"}
CLAIM_KEYS = {"claim", "compare", "key", "about"}
COMPARE_KEYS = {"left", "op", "right", "beyond"}
BEYOND = ["spread"]
"""What a claim may have to clear besides its comparison: the seeds' spread."""
REF_KEYS = {"row", "column"}
MATCH_KEYS = ["experiment", "table", "budget", "method", "method_label", "task", "num_agents", "seed", "rules",
              "lowlevel"]  # fmt: skip
"""The fields of a job (`JobResult`) a declaration may match; the variant is the table's own."""
REACH = "env_steps_to_reach"
"""The metric of a column of env-steps (M) to the learning curve's rate (its label may say `{reach_pct}` and
`{curve_eval}`: the rate in % and the curve's evaluation, by `eval_labels`)."""
METRICS = ["success_rate", "completion_time", "completion_time_s", "path_length_m", REACH]
"""The numbers of an evaluation's record a column may read, and the curves' env-steps to their rate."""
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
    beyond: str = ""  # "spread": the cells must differ by more than the seeds' spread
    key: str = ""  # the finding's key and about (`Finding`); the key defaults to the claim's words
    about: str = ""


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
    metric, row, column or paper number, with the valid choices."""
    where = Path(path).name
    decl = _keys(where, yaml.safe_load(Path(path).read_text()), KEYS, {"name", "title", "rows", "columns"})
    decl = {"row_header": ["Row"], "jobs": {}, "note": "", "claims": [], "curves": "", "readings": [],
            "eval_labels": {}, **decl}  # fmt: skip
    _keys(f"{where} jobs", decl["jobs"], set(MATCH_KEYS))
    rows, columns = {}, {}
    for row in decl["rows"]:
        _keys(f"{where} row", row, ROW_KEYS, ROW_KEYS - {"label"})
        _keys(f"{where} row {row['id']!r} match", row["match"], set(MATCH_KEYS))
        label = row.get("label") or _method_label(f"{where} row {row['id']!r}", row["match"])
        label = label if isinstance(label, list) else [label]
        if len(label) != len(decl["row_header"]):
            raise BadInput(f"{where} row {row['id']!r}: {len(label)} labels for row_header {decl['row_header']}")
        rows[row["id"]] = {**row, "label": [str(x) for x in label]}
    evals = experiment_evals(decl["jobs"].get("table"))
    for column in decl["columns"]:
        _keys(f"{where} column", column, COLUMN_KEYS, {"id", "label", "metric"})
        name = column["id"]
        _choice(f"{where} column {name!r} metric", column["metric"], METRICS)
        if column["metric"] != REACH:
            _choice(f"{where} column {name!r} eval", column.get("eval"), evals)
        paper = _paper(f"{where} column {name!r} paper", column.get("paper") or {})
        for row in paper:
            _choice(f"{where} column {name!r} paper row", row, list(rows))
        columns[name] = {"scale": 1.0, "digits": 1, **column, "paper": paper}
    for name in decl["readings"]:
        _choice(f"{where} reading", name, list(columns))
    claims = [_claim(f"{where} claim", c, rows, columns) for c in decl["claims"]]
    return {**decl, "rows": rows, "columns": columns, "claims": claims}


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


def _claim(where: str, given, rows: dict, columns: dict) -> Claim:
    given = _keys(where, given, CLAIM_KEYS, {"claim", "compare"})
    where = f"{where} {given['claim']!r}"
    compare = _keys(where, given["compare"], COMPARE_KEYS, COMPARE_KEYS - {"beyond"})
    _choice(f"{where} op (the claim's kind)", compare["op"], list(OPS))
    if "beyond" in compare:
        _choice(f"{where} beyond", compare["beyond"], BEYOND)

    def ref(side: str, value):
        if isinstance(value, int | float) and side == "right":
            return float(value)
        value = _keys(f"{where} {side}", value, REF_KEYS, REF_KEYS)
        _choice(f"{where} {side} row", value["row"], list(rows))
        _choice(f"{where} {side} column", value["column"], list(columns))
        return Ref(value["row"], value["column"])

    text = str(given["claim"])
    left, right = ref("left", compare["left"]), ref("right", compare["right"])
    return Claim(text, left, compare["op"], right, compare.get("beyond", ""), str(given.get("key", text)),
                 str(given.get("about", "")))  # fmt: skip


def build(decl: dict, results: list[JobResult], variant: str) -> Table:
    """The declared table of `variant`: a cell per row and column from the jobs that match both, its claims
    judged on their means."""
    jobs = matching(results, **decl["jobs"], variant=variant)
    lines = {" / ".join(row["label"]): matching(jobs, **row["match"]) for row in decl["rows"].values()}
    words = _label_words(decl, jobs)
    cells: dict[tuple[str, str], Cell] = {}
    missing = []
    for row_id, row in decl["rows"].items():
        for col_id, col in decl["columns"].items():
            if col["metric"] == REACH:
                cell, lack = reach_cell(matching(jobs, **row["match"])), "no learning curve"
            else:
                cell = collect(jobs, col["metric"], float(col["scale"]), **row["match"], eval=col["eval"])
                lack = "no finished job"
            cell.digits = int(col["digits"])
            paper = col["paper"].get(row_id)
            cell.paper = tuple(float(x) for x in paper) if paper else None
            if not cell.values and not cell.unreached:
                missing.append(f"{' / '.join(row['label'])} / {col['label'].format(**words)}: {lack}")
            cells[row_id, col_id] = cell
    rows = [(row["label"], [cells[row_id, c] for c in decl["columns"]]) for row_id, row in decl["rows"].items()]
    findings = [judge(claim, cells, decl) for claim in decl["claims"]]
    findings += [_reading(decl, name, cells, words) for name in decl["readings"]]
    curves = {decl["curves"].format(**words): lines} if decl["curves"] else {}
    if curves:
        findings += curve_findings.budget_findings(lines)
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
        also_behind=[r for r in jobs if r.table != decl["name"] and any(matching([r], **row["match"])
                                                                        for row in decl["rows"].values())],
    )  # fmt: skip


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
    parts = [(" / ".join(row["label"]), cells[row_id, name]) for row_id, row in decl["rows"].items()]
    numbers = {row: cell.mean for row, cell in parts if cell.values}
    return Finding(f"{label}: {'; '.join(f'{row} {cell.text()}' for row, cell in parts)}", None, numbers,
                   key="reading", about=label)  # fmt: skip


def judge(claim: Claim, cells: dict[tuple[str, str], Cell], decl: dict) -> Finding:
    """The claim's finding: True or False on the cells' means (beyond their spread where it says so), None where
    a cell it reads is empty or the difference lies within the spread."""
    numbers, names, stds = {}, {}, []
    for side, ref in (("left", claim.left), ("right", claim.right)):
        if isinstance(ref, float):
            numbers[side], names[side] = ref, ""
            continue
        names[side] = f"{' / '.join(decl['rows'][ref.row]['label'])}, {decl['columns'][ref.column]['label']}"
        cell = cells[ref.row, ref.column]
        if cell.values:
            numbers[side] = cell.mean
            stds.append(cell.std)
    holds = bool(OPS[claim.op][0](numbers["left"], numbers["right"])) if len(numbers) == 2 else None
    if claim.beyond and holds is not None:
        numbers["spread"] = float(np.hypot(*stds)) if len(stds) == 2 else (stds or [0.0])[0]
        towards = numbers["left"] - numbers["right"] if claim.op in (">", ">=") else numbers["right"] - numbers["left"]
        holds = True if towards > numbers["spread"] else (False if not holds else None)
    finding = Finding("", holds, numbers, claim=claim.text, op=claim.op, names=names, key=claim.key,
                      about=claim.about)  # fmt: skip
    return dataclasses.replace(finding, text=claim_sentence(finding))


def claim_sentence(finding: Finding) -> str:
    """A claim's finding in words: "Ours beats SA on the cuboid: does not hold: Cuboid / Ours, S.R. (%) 60.0 is
    not above Cuboid / SA, S.R. (%) 62.0 (means over seeds)"; weighed against the seeds' spread, it says so."""
    if finding.holds is None and len(finding.numbers) < 2:
        unmeasured = [finding.names[side] for side in ("left", "right") if side not in finding.numbers]
        return f"{finding.claim}: not measured: no finished job for {'; '.join(unmeasured)}"
    left, right = (
        " ".join(filter(None, [finding.names[side], f"{finding.numbers[side]:.1f}"])) for side in ("left", "right")
    )
    spread = finding.numbers.get("spread")
    if finding.holds is None:  # the right way, within the spread
        return (f"{finding.claim}: within the seeds' spread: {left} is {OPS[finding.op][1]} {right}, by less than "
                f"the seeds' spread {spread:.1f} (means over seeds; both stds in quadrature)")  # fmt: skip
    verdict, negation = ("holds", "") if finding.holds else ("does not hold", "not ")
    beyond = f" by more than the seeds' spread {spread:.1f}" if spread is not None and finding.holds else ""
    weighed = "; both stds in quadrature" if spread is not None else ""
    compared = f"{left} is {negation}{OPS[finding.op][1]} {right}{beyond}"
    return f"{finding.claim}: {verdict}: {compared} (means over seeds{weighed})"


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
