"""Reading the JSON records mapush writes (a job's `result.json`, an evaluation's `eval.json`, a run's
`meta.json`) as data that may be cut or altered: `read_json` refuses what is not JSON, or holds NaN or Infinity
(which Python's json reads by default, and a table would print as `nan ± nan`), and `check_fields` refuses a
field of the wrong type, each as one BadInput line naming the file and the field."""

from __future__ import annotations

import json
import math
from pathlib import Path

from mapush.errors import BadInput

NUMBER, INTEGER, TEXT, ANY = "a finite number", "an integer", "a string", "anything"
"""Leaf types of a field spec (`check_fields`)."""


class ListOf(tuple):
    """A spec: a list whose every item is of the spec it holds, `ListOf((spec,))`."""


class MapOf(tuple):
    """A spec: a mapping (string keys) whose every value is of the spec it holds, `MapOf((spec,))`."""


class Nullable(tuple):
    """A spec: null, or a value of the spec it holds, `Nullable((spec,))`."""


class Fields(dict):
    """A spec: a mapping whose listed fields (field -> spec), where present, are of their spec, and which has every
    field of `required`; other fields are free."""

    def __init__(self, fields: dict, required: tuple[str, ...] = ()):
        super().__init__(fields)
        self.required = required


def _not_finite(text: str) -> float:
    raise ValueError(f"{text} is not a finite number")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):  # 1e999 reads as inf
        raise ValueError(f"{text} is not a finite number")
    return value


def loads(text: str, what: str) -> object:
    """JSON `text` (from `what`, named in the message) without NaN or Infinity; BadInput otherwise."""
    try:
        return json.loads(text, parse_constant=_not_finite, parse_float=_finite)
    except ValueError as err:  # JSONDecodeError, and the refusals above
        raise BadInput(
            f"{what} is not a readable JSON record ({str(err).splitlines()[0]}): cut or altered; valid: the file as "
            "mapush wrote it (finite numbers, complete)"
        ) from None


def read_json(path: Path | str, what: str | None = None) -> object:
    """The JSON record at `path` (`loads`); BadInput for one cut, altered or not text (OSError passes on)."""
    try:
        text = Path(path).read_text()
    except UnicodeDecodeError:
        raise BadInput(f"{what or path} is not text (not UTF-8); valid: the file as mapush wrote it") from None
    return loads(text, str(what or path))


def read_meta(path: Path | str) -> dict:
    """A run's `meta.json` at `path`; BadInput naming it when cut or altered (not a record, `lengthened` no list)."""
    meta = read_json(path)
    check_fields(meta, Fields({"lengthened": ListOf((ANY,))}), str(path))
    return meta


def check_fields(value: object, spec: object, what: str, where: str = "") -> None:
    """BadInput naming `what` (the file) and the field `where` unless `value` is of `spec`: a leaf type (`NUMBER`,
    `INTEGER`, `TEXT`, `ANY`), `ListOf`, `MapOf`, `Nullable` or `Fields`."""
    kind = _kind(value, spec)
    if kind is not None:
        shown = json.dumps(value)[:40] if _dumpable(value) else repr(value)[:40]
        field = where or "(the whole record)"
        raise BadInput(f"{what}: field {field} is {shown}; valid: {kind} (the file as mapush wrote it)")
    if isinstance(spec, ListOf):
        for i, item in enumerate(value):
            check_fields(item, spec[0], what, f"{where}[{i}]")
    elif isinstance(spec, MapOf):
        for key, item in value.items():
            check_fields(item, spec[0], what, f"{where}.{key}")
    elif isinstance(spec, Nullable):
        if value is not None:
            check_fields(value, spec[0], what, where)
    elif isinstance(spec, Fields):
        missing = [k for k in spec.required if k not in value]
        if missing:
            field = f"{where}.{missing[0]}" if where else missing[0]
            raise BadInput(f"{what}: field {field} is missing; valid: the file as mapush wrote it")
        for key, sub in spec.items():
            if key in value:
                check_fields(value[key], sub, what, f"{where}.{key}" if where else key)


def _kind(value: object, spec: object) -> str | None:
    """What `value` should have been when it is not of `spec` (its outer type only), else None."""
    if spec == ANY or (isinstance(spec, Nullable) and value is None):
        return None
    if isinstance(spec, Nullable):
        return _kind(value, spec[0]) and f"{_kind(value, spec[0])} or null"
    if spec == NUMBER:
        number = isinstance(value, int | float) and not isinstance(value, bool)
        return None if number and math.isfinite(value) else NUMBER
    if spec == INTEGER:
        return None if isinstance(value, int) and not isinstance(value, bool) else INTEGER
    if spec == TEXT:
        return None if isinstance(value, str) else TEXT
    if isinstance(spec, ListOf):
        return None if isinstance(value, list) else "a list"
    if isinstance(spec, MapOf | Fields):
        return None if isinstance(value, dict) and all(isinstance(k, str) for k in value) else "a mapping"
    raise TypeError(f"not a field spec: {spec!r}")


def _dumpable(value: object) -> bool:
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        return False
    return True
