"""A declared table's claims (`declared.py`): what each compares, read from its YAML and checked (`parse`), judged
on the table's cells (`judge`) and put in words in one place (`claim_sentence`).

A claim compares one cell's mean over seeds with another cell's, a number, or a number of the paper's (`OPS`), or
says that a cell is the highest or lowest of a set of rows in its column (`EXTREMES`). Its finding holds True or
False, or None where a cell it reads has no finished job. With `spread` it weighs the seeds' spread (both cells'
stds in quadrature): `beyond`, it holds only where the cells differ the claimed way by more than the spread (None
between, False where they do not differ that way at all); `within`, a shortfall within the spread is None, not
False. A claim that reads a cell of jobs made by an earlier recipe (†) says so.
"""

from __future__ import annotations

import dataclasses
import operator
from dataclasses import dataclass

import numpy as np

from mapush.errors import BadInput
from mapush.report.formats import OTHERWISE, Cell, Finding

CLAIM_KEYS = {"claim", "compare", "key", "about"}
COMPARE_KEYS = {"left", "op", "right", "among", "spread"}
REF_KEYS = {"row", "column"}
OPS = {">": (operator.gt, "above"), "<": (operator.lt, "below"), ">=": (operator.ge, "at or above"),
       "<=": (operator.le, "at or below")}  # fmt: skip
"""A cell above or below another cell or a number (means over seeds)."""
EXTREMES = {"highest": max, "lowest": min}
"""A cell the highest or lowest of the `among` rows' cells in its column, strictly (a tie is neither)."""
SPREADS = ["beyond", "within"]
"""How a comparison weighs the seeds' spread."""


@dataclass(frozen=True)
class Ref:
    row: str
    column: str


@dataclass(frozen=True)
class Claim:
    text: str
    left: Ref
    op: str
    right: Ref | float | None = None  # None for an extreme
    among: tuple[str, ...] = ()  # an extreme's rows
    spread: str = ""  # "beyond" or "within" (SPREADS)
    key: str = ""  # the finding's key and about (`Finding`); the key defaults to the claim's words
    about: str = ""


def checked_keys(where: str, given, known: set[str], required: set[str] = frozenset()) -> dict:
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


def checked_choice(where: str, value, valid) -> None:
    if value not in valid:
        raise BadInput(f"{where}: unknown {value!r}; valid: {', '.join(str(v) for v in valid)}")


def parse(where: str, given, rows: dict, columns: dict, paper_number) -> Claim:
    """One claim of a declaration, checked against its `rows` and `columns`; `paper_number(where, path)` reads a
    right side given as `{paper: dotted.path}`."""
    given = checked_keys(where, given, CLAIM_KEYS, {"claim", "compare"})
    where = f"{where} {given['claim']!r}"
    compare = checked_keys(where, given["compare"], COMPARE_KEYS, {"left", "op"})
    checked_choice(f"{where} op (the claim's kind)", compare["op"], [*OPS, *EXTREMES])
    if "spread" in compare:
        checked_choice(f"{where} spread", compare["spread"], SPREADS)

    def ref(side: str, value) -> Ref:
        value = checked_keys(f"{where} {side}", value, REF_KEYS, REF_KEYS)
        checked_choice(f"{where} {side} row", value["row"], list(rows))
        checked_choice(f"{where} {side} column", value["column"], list(columns))
        return Ref(value["row"], value["column"])

    left, right, among = ref("left", compare["left"]), None, ()
    extreme = compare["op"] in EXTREMES
    for key, needs in (("among", True), ("right", False)):
        if key in compare and extreme != needs:
            kinds = ", ".join(EXTREMES) if needs else ", ".join(OPS)
            raise BadInput(f"{where}: {key!r} is for op {kinds} only, not {compare['op']!r}")
    if extreme:
        among = tuple(compare.get("among") or ())
        for row in among:
            checked_choice(f"{where} among", row, list(rows))
        if left.row not in among or len(among) < 2:
            raise BadInput(f"{where}: among must list the left row {left.row!r} and another; got {list(among)}")
    elif "right" not in compare:
        raise BadInput(f"{where}: missing key 'right'; required for op {compare['op']!r}")
    elif isinstance(compare["right"], int | float):
        right = float(compare["right"])
    elif isinstance(compare["right"], dict) and set(compare["right"]) == {"paper"}:
        right = _number(f"{where} right", paper_number(f"{where} right", compare["right"]["paper"]))
    else:
        right = ref("right", compare["right"])
    text = str(given["claim"])
    return Claim(text, left, compare["op"], right, among, compare.get("spread", ""), str(given.get("key", text)),
                 str(given.get("about", "")))  # fmt: skip


def _number(where: str, value) -> float:
    """A paper number: a number, or the mean of a [mean, std] pair."""
    if isinstance(value, list) and len(value) == 2:
        value = value[0]
    if not isinstance(value, int | float):
        raise BadInput(f"{where}: {value!r} is not a number of the paper's; valid: a number or [mean, std]")
    return float(value)


def judge(claim: Claim, cells: dict[tuple[str, str], Cell], rows: dict, columns: dict) -> Finding:
    """The claim's finding on the table's cells (`rows` and `columns` as the declaration gives them)."""

    def name(ref: Ref) -> str:
        return f"{rows[ref.row]['name']}, {columns[ref.column]['label']}"

    read = [claim.left, *([claim.right] if isinstance(claim.right, Ref) else []),
            *(Ref(row, claim.left.column) for row in claim.among)]  # fmt: skip
    marked = sum(bool(cells[r.row, r.column].otherwise) for r in set(read))
    if claim.op in EXTREMES:
        means = {r: cells[r, claim.left.column].mean for r in claim.among if cells[r, claim.left.column].values}
        numbers = {rows[r]["name"]: m for r, m in means.items()}
        holds = None
        if claim.left.row in means and len(means) > 1:  # strictly: a tie is no highest or lowest
            others = [m for r, m in means.items() if r != claim.left.row]
            mine, theirs = means[claim.left.row], EXTREMES[claim.op](others)
            holds = bool(mine > theirs if claim.op == "highest" else mine < theirs) and not np.isclose(mine, theirs)
        names = {"left": rows[claim.left.row]["name"], "column": columns[claim.left.column]["label"]}
        names["digits"] = str(columns[claim.left.column]["digits"])
    else:
        numbers, stds = {}, []
        names = {"digits": str(columns[claim.left.column]["digits"])}
        for side, ref in (("left", claim.left), ("right", claim.right)):
            if isinstance(ref, float):
                numbers[side], names[side] = ref, ""
                continue
            names[side] = name(ref)
            if cells[ref.row, ref.column].values:
                numbers[side] = cells[ref.row, ref.column].mean
                stds.append(cells[ref.row, ref.column].std)
        holds = bool(OPS[claim.op][0](numbers["left"], numbers["right"])) if len(numbers) == 2 else None
        if claim.spread and holds is not None:
            numbers["spread"] = float(np.hypot(*stds)) if len(stds) == 2 else stds[0]
            left, right = numbers["left"], numbers["right"]
            towards = left - right if claim.op in (">", ">=") else right - left
            if claim.spread == "beyond":
                holds = True if towards > numbers["spread"] else (False if not holds else None)
            elif not holds:
                holds = None if -towards <= numbers["spread"] else False
    if marked:
        numbers["cells_made_otherwise"] = float(marked)
    finding = Finding("", holds, numbers, claim=claim.text, op=claim.op, names=names, key=claim.key,
                      about=claim.about)  # fmt: skip
    return dataclasses.replace(finding, text=claim_sentence(finding, claim.spread))


def claim_sentence(finding: Finding, spread: str = "") -> str:
    """A claim's finding in words: "Ours beats SA on the cuboid: does not hold: Cuboid / Ours, S.R. (%) 60.0 is
    not above Cuboid / SA, S.R. (%) 62.0 (means over seeds)"; weighed against the seeds' spread, it says so."""
    numbers, digits = finding.numbers, int(finding.names.get("digits", 1))
    marked = f" (cells marked {OTHERWISE}: an earlier recipe's)" if "cells_made_otherwise" in numbers else ""
    if finding.op in EXTREMES:
        if finding.holds is None:
            return f"{finding.claim}: not measured: no finished job for {finding.names['left']} or any other row"
        means = {row: v for row, v in numbers.items() if row != "cells_made_otherwise"}
        top = next(row for row, v in means.items() if v == EXTREMES[finding.op](means.values()))
        verdict = "holds" if finding.holds else "does not hold"
        text = (
            f"{finding.claim}: {verdict}: the {finding.op} {finding.names['column']}: {top} ({means[top]:.{digits}f})"
        )
        if not finding.holds:
            text += f", not {finding.names['left']} ({means[finding.names['left']]:.{digits}f})"
        return text + f" (means over seeds){marked}"
    if "left" not in numbers or "right" not in numbers:
        unmeasured = [finding.names[side] for side in ("left", "right") if side not in numbers]
        return f"{finding.claim}: not measured: no finished job for {'; '.join(unmeasured)}"
    left, right = (
        " ".join(filter(None, [finding.names[side], f"{numbers[side]:.{digits}f}"])) for side in ("left", "right")
    )
    stds = "both stds in quadrature" if finding.names["right"] else "its std"
    how, weighed = OPS[finding.op][1], f"; {stds}" if spread else ""
    if finding.holds is None:  # within the spread
        towards = "by less than" if spread == "beyond" else "short by no more than"
        text = f"within the seeds' spread: {left} is {'' if spread == 'beyond' else 'not '}{how} {right}, {towards}"
        text += f" the seeds' spread {numbers['spread']:.{digits}f}"
    else:
        beyond = f" by more than the seeds' spread {numbers['spread']:.{digits}f}" if spread == "beyond" else ""
        beyond = beyond if finding.holds else ""
        verdict, negation = ("holds", "") if finding.holds else ("does not hold", "not ")
        text = f"{verdict}: {left} is {negation}{how} {right}{beyond}"
    return f"{finding.claim}: {text} (means over seeds{weighed}){marked}"
