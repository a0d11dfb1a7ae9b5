"""A declared table's claims (`declared.py`): what each compares, read from its YAML and checked (`parse`), judged
on the table's cells (`judge`) and put in words in one place (`claim_sentence`).

A claim compares one cell's mean over seeds with another cell's, a number, or a number of the paper's (`OPS`), or
says that a cell is the highest or lowest of a set of rows in its column (`EXTREMES`). Its finding holds True or
False, or None where a cell it reads has no finished job. With `spread` it weighs the seeds' spread (both cells'
stds in quadrature): `beyond`, it holds only where the cells differ the claimed way by more than the spread (None
between, False where they do not differ that way at all); `within`, a shortfall within the spread is None, not
False. A claim that reads a cell of jobs made by an earlier recipe (†) says so.

A claim `along: columns` names rows only: it is judged in every column in turn (`judge_along`), and its finding
names the first column at which it stops holding (the ladder's rungs), where it held before, and where it was
within the seeds' spread, not measured or not applicable.
"""

from __future__ import annotations

import dataclasses
import operator
from dataclasses import dataclass

import numpy as np

from mapush.errors import BadInput
from mapush.report.formats import OTHERWISE, Cell, Finding

CLAIM_KEYS = {"claim", "compare", "key", "about", "along"}
COMPARE_KEYS = {"left", "op", "right", "among", "spread"}
REF_KEYS = {"row", "column"}
OPS = {">": (operator.gt, "above"), "<": (operator.lt, "below"), ">=": (operator.ge, "at or above"),
       "<=": (operator.le, "at or below")}  # fmt: skip
"""A cell above or below another cell or a number (means over seeds)."""
EXTREMES = {"highest": max, "lowest": min}
"""A cell the highest or lowest of the `among` rows' cells in its column, strictly (a tie is neither)."""
SPREADS = ["beyond", "within"]
"""How a comparison weighs the seeds' spread."""
ALONG = ["columns"]
"""What a claim may be judged along, cell by cell: every column, in order."""


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
    along: bool = False  # judged in every column (its refs' column is ""), `judge_along`


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
    for name in ("claim", "key", "about"):
        if name in given and not isinstance(given[name], str):
            raise BadInput(f"{where}: {name} {given[name]!r} is not text; valid: a string")
    where = f"{where} {given['claim']!r}"
    compare = checked_keys(where, given["compare"], COMPARE_KEYS, {"left", "op"})
    checked_choice(f"{where} op (the claim's kind)", compare["op"], [*OPS, *EXTREMES])
    extreme = compare["op"] in EXTREMES
    for key, needs in (("among", True), ("right", False), ("spread", False)):
        if key in compare and extreme != needs:
            kinds = ", ".join(EXTREMES) if needs else ", ".join(OPS)
            raise BadInput(f"{where}: {key!r} is for op {kinds} only, not {compare['op']!r}")
    if "spread" in compare:
        checked_choice(f"{where} spread", compare["spread"], SPREADS)
    along = "along" in given
    if along:
        checked_choice(f"{where} along", given["along"], ALONG)

    def ref(side: str, value) -> Ref:
        known = {"row"} if along else REF_KEYS  # along the columns, a side names its row only
        value = checked_keys(f"{where} {side}{' (along columns: a row only)' if along else ''}", value, known, known)
        checked_choice(f"{where} {side} row", value["row"], list(rows))
        if along:
            return Ref(value["row"], "")
        checked_choice(f"{where} {side} column", value["column"], list(columns))
        return Ref(value["row"], value["column"])

    left, right, among = ref("left", compare["left"]), None, ()
    if extreme:
        among = compare.get("among")
        if not isinstance(among, list) or len(set(map(str, among))) != len(among) or len(among) < 2:
            raise BadInput(f"{where}: among {among!r} is not a list of two or more rows; valid: rows of {list(rows)}")
        for row in among:
            checked_choice(f"{where} among", row, list(rows))
        if left.row not in among:
            raise BadInput(f"{where}: among {among} lacks the left row {left.row!r}")
        among = tuple(among)
    elif "right" not in compare:
        raise BadInput(f"{where}: missing key 'right'; required for op {compare['op']!r}")
    elif isinstance(compare["right"], int | float) and not isinstance(compare["right"], bool):
        right = float(compare["right"])
    elif isinstance(compare["right"], dict) and set(compare["right"]) == {"paper"}:
        path = compare["right"]["paper"]
        if not isinstance(path, str):
            raise BadInput(f"{where} right: paper {path!r} is not a path; valid: a dotted path into paper.yaml")
        right = _number(f"{where} right", paper_number(f"{where} right", path))
    else:
        right = ref("right", compare["right"])
    text = given["claim"]
    return Claim(text, left, compare["op"], right, among, compare.get("spread", ""), given.get("key", text),
                 given.get("about", ""), along)  # fmt: skip


def _number(where: str, value) -> float:
    """A paper number: a number, or the mean of a [mean, std] pair."""
    if isinstance(value, list) and len(value) == 2:
        value = value[0]
    if not isinstance(value, int | float) or isinstance(value, bool):
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
        column = claim.left.column
        means = {r: cells[r, column].mean for r in claim.among if cells[r, column].values}
        numbers = {rows[r]["name"]: m for r, m in means.items()}
        names = {"left": rows[claim.left.row]["name"], "column": columns[column]["label"]}
        holds = None
        if claim.left.row in means and len(means) > 1:  # strictly: a tie is no highest or lowest
            others = {r: m for r, m in means.items() if r != claim.left.row}
            best = EXTREMES[claim.op](others, key=others.get)
            mine, theirs = means[claim.left.row], others[best]
            holds = bool(mine > theirs if claim.op == "highest" else mine < theirs) and not np.isclose(mine, theirs)
            names["other"] = rows[best]["name"]  # the best of the others: who beats or ties it
    else:
        numbers, stds, seeds = {}, [], []
        names = {}
        for side, ref in (("left", claim.left), ("right", claim.right)):
            if isinstance(ref, float):
                numbers[side], names[side] = ref, ""
                continue
            names[side] = name(ref)
            if cells[ref.row, ref.column].values:
                numbers[side] = cells[ref.row, ref.column].mean
                stds.append(cells[ref.row, ref.column].std)
                seeds.append(len(cells[ref.row, ref.column].values))
        holds = bool(OPS[claim.op][0](numbers["left"], numbers["right"])) if len(numbers) == 2 else None
        if claim.spread and holds is not None:
            holds = _weighed(claim, holds, numbers, stds, seeds)
    names["digits"] = str(columns[claim.left.column]["digits"])
    if marked:
        numbers["cells_made_otherwise"] = float(marked)
    finding = Finding("", holds, numbers, claim=claim.text, op=claim.op, names=names, key=claim.key,
                      about=claim.about)  # fmt: skip
    return dataclasses.replace(finding, text=claim_sentence(finding, claim.spread))


def _weighed(claim: Claim, holds: bool, numbers: dict, stds: list[float], seeds: list[int]) -> bool | None:
    """A comparison's verdict weighed against the seeds' spread (adds `spread` to `numbers`); None where a cell has
    one seed (no spread to weigh) or the difference lies within the spread."""
    if min(seeds) < 2:
        return None
    numbers["spread"] = float(np.hypot(*stds)) if len(stds) == 2 else stds[0]
    towards = numbers["left"] - numbers["right"] if claim.op in (">", ">=") else numbers["right"] - numbers["left"]
    inclusive = claim.op in (">=", "<=")
    if claim.spread == "beyond":  # clears the spread, or does not differ the claimed way at all
        clears = towards >= numbers["spread"] if inclusive else towards > numbers["spread"]
        return True if clears else (False if not holds else None)
    return True if holds else (None if 0 < numbers["spread"] >= -towards else False)  # within: a small shortfall


def claim_sentence(finding: Finding, spread: str = "") -> str:
    """A claim's finding in words: "Ours beats SA on the cuboid: does not hold: Cuboid / Ours, S.R. (%) 60.0 is
    not above Cuboid / SA, S.R. (%) 62.0 (means over seeds)"; weighed against the seeds' spread, it says so."""
    numbers, names, digits = finding.numbers, finding.names, int(finding.names.get("digits", 1))
    marked = f" (cells marked {OTHERWISE}: an earlier recipe's)" if "cells_made_otherwise" in numbers else ""
    if finding.op in EXTREMES:
        if finding.holds is None:
            lacking = names["left"] if names["left"] not in numbers else "any other row"
            return f"{finding.claim}: not measured: no finished job for {lacking}{marked}"
        mine, theirs = numbers[names["left"]], numbers[names["other"]]
        if finding.holds:
            text = f"holds: the {finding.op} {names['column']}: {names['left']} ({mine:.{digits}f}; next "
            text += f"{names['other']}, {theirs:.{digits}f})"
        else:
            how = "ties with" if np.isclose(mine, theirs) else ("is below" if finding.op == "highest" else "is above")
            text = f"does not hold: {names['left']} ({mine:.{digits}f}) {how} {names['other']} ({theirs:.{digits}f})"
        return f"{finding.claim}: {text}, {names['column']} (means over seeds){marked}"
    if "left" not in numbers or "right" not in numbers:
        unmeasured = [names[side] for side in ("left", "right") if side not in numbers]
        return f"{finding.claim}: not measured: no finished job for {'; '.join(unmeasured)}{marked}"
    left, right = (" ".join(filter(None, [names[side], f"{numbers[side]:.{digits}f}"])) for side in ("left", "right"))
    how = OPS[finding.op][1]
    if spread and "spread" not in numbers:
        return f"{finding.claim}: not judged: {left} against {right}, a cell of one seed has no spread to weigh{marked}"
    stds = "both stds in quadrature" if names["right"] else "its std"
    weighed = f"; {stds}" if spread else ""
    if finding.holds is None:  # within the spread
        towards = "by less than" if spread == "beyond" else "short by no more than"
        text = f"within the seeds' spread: {left} is {'' if spread == 'beyond' else 'not '}{how} {right}, {towards}"
        text += f" the seeds' spread {numbers['spread']:.{digits}f}"
    else:
        beyond = f" by more than the seeds' spread {numbers['spread']:.{digits}f}" if spread == "beyond" else ""
        verdict, negation = ("holds", "") if finding.holds else ("does not hold", "not ")
        text = f"{verdict}: {left} is {negation}{how} {right}{beyond if finding.holds else ''}"
    return f"{finding.claim}: {text} (means over seeds{weighed}){marked}"


def judge_along(claim: Claim, cells: dict[tuple[str, str], Cell], rows: dict, columns: dict,
                noun: str = "column") -> Finding:  # fmt: skip
    """An `along: columns` claim judged in each column in order (each a `noun`: "rung"): it holds False from the
    first column measured where it does not hold, True where it held in every column measured, None where it was
    judged in none or, failing nowhere, lay within the seeds' spread (or was not judged, a cell of one seed) in
    some. The finding names that column, those before it where it held (if any), and those where it lay within the
    spread, was not judged, was not measured (a cell it reads is empty) or is not applicable; `first_failing_<noun>` and
    `unmeasured_before` count where it failed and how many columns before that went unmeasured."""
    judged, unmeasured, inapplicable = [], [], []
    for k, column in enumerate(columns):
        right = Ref(claim.right.row, column) if isinstance(claim.right, Ref) else claim.right
        at = dataclasses.replace(claim, along=False, left=Ref(claim.left.row, column), right=right)
        read = [at.left, *([at.right] if isinstance(at.right, Ref) else []), *(Ref(r, column) for r in at.among)]
        if not all(cells[r.row, r.column].applicable for r in read):
            inapplicable.append((k, columns[column]["label"]))
        elif not all(cells[r.row, r.column].values for r in read):
            unmeasured.append((k, columns[column]["label"]))
        else:
            judged.append((k, columns[column]["label"], judge(at, cells, rows, columns)))
    failing = next((j for j in judged if j[2].holds is False), None)
    open_ = [j for j in judged if j[2].holds is None]  # within the spread, or a one-seed cell: not judged
    within = [label for _, label, found in open_ if "spread" in found.numbers]
    one_seed = [label for _, label, found in open_ if "spread" not in found.numbers]
    numbers = {f"unmeasured_{noun}s": float(len(unmeasured))}
    marked = sum(found.numbers.get("cells_made_otherwise", 0.0) for _, _, found in judged)
    if marked:
        numbers["cells_made_otherwise"] = marked
    if not judged:
        holds, text, names = None, f"not measured at any {noun}", {}
    elif failing is not None:
        k, label, found = failing
        held = [other for j, other, f in judged if j < k and f.holds]
        before = [other for j, other in unmeasured if j < k]
        holds, names = False, {**found.names, "at": label}
        first = f"first stops holding at {label}"
        if before:  # the columns before it went unmeasured: it may fail there too
            first = f"stops holding at {label}, the first {noun} measured to fail"
        text = f"{first} ({_body(claim, found)})" + (f"; held at {', '.join(held)}" if held else "")
        numbers |= {f"first_failing_{noun}": float(k), "unmeasured_before": float(len(before)), **found.numbers}
    else:
        _, label, found = judged[-1]
        holds, names = (None if open_ else True), {**found.names, "at": label}
        text = f"holds at every {noun} measured (at {label}: {_body(claim, found)})" if not open_ else (
            f"fails at no {noun} measured")  # fmt: skip
    for what, where in (("within the seeds' spread", within), ("not judged (a cell of one seed)", one_seed),
                        ("not measured", [label for _, label in unmeasured]),
                        ("not applicable", [label for _, label in inapplicable])):  # fmt: skip
        text += f"; {what} at {', '.join(where)}" if where else ""
    text += f" (cells marked {OTHERWISE}: an earlier recipe's)" if marked else ""
    return Finding(f"{claim.text}: {text}", holds, numbers, claim=claim.text, op=claim.op, names=names,
                   key=claim.key, about=claim.about)  # fmt: skip


def _body(claim: Claim, found: Finding) -> str:
    """A one-column finding's words without the claim, its verdict and its † words (the along finding says them
    once): what it rests on."""
    body = found.text.removeprefix(f"{claim.text}: ").removesuffix(f" (cells marked {OTHERWISE}: an earlier recipe's)")
    for verdict in ("holds: ", "does not hold: "):
        body = body.removeprefix(verdict)
    if found.op in EXTREMES and "column" in found.names:  # the along finding names the column already
        body = body.replace(f", {found.names['column']} (means over seeds)", " (means over seeds)")
    return body
