"""Reading the JSON records mapush writes (a job's `result.json`, an evaluation's `eval.json`, a run's
`meta.json`) as data that may be cut or altered: `read_json` refuses what is not JSON, or holds NaN or Infinity
(which Python's json reads by default, and a table would print as `nan ± nan`), and `check_schema` refuses a
record that its JSON Schema does not describe (a field of the wrong type, one missing), each as one BadInput line
naming the file and the field."""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

from mapush.errors import BadInput


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


META = {"type": "object", "properties": {"lengthened": {"type": "array"}}}
"""What is read of a run's `meta.json` (JSON Schema): a record, its `lengthened` steps a list."""


def read_meta(path: Path | str) -> dict:
    """A run's `meta.json` at `path`; BadInput naming it when cut or altered (`META`)."""
    meta = read_json(path)
    check_schema(meta, META, str(path))
    return meta


KINDS = {"number": "a finite number", "integer": "an integer", "string": "a string", "array": "a list",
         "object": "a mapping", "null": "null"}  # fmt: skip
"""JSON Schema's types as a message names them."""


def check_schema(value: object, schema: dict, what: str) -> None:
    """BadInput naming `what` (the file) and the first field of `value` that the JSON Schema `schema` refuses
    (validated by jsonschema), with what is valid there."""
    error = best_match(_validator(json.dumps(schema, sort_keys=True)).iter_errors(value))
    if error is None:
        return
    field = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
    if error.validator == "required":
        missing = error.message.split("'")[1]
        raise BadInput(f"{what}: field {f'{field}.' if field else ''}{missing} is missing; valid: the file as mapush "
                       "wrote it")  # fmt: skip
    expected = error.validator_value if error.validator == "type" else None
    names = [expected] if isinstance(expected, str) else list(expected or [])
    valid = " or ".join(KINDS.get(n, n) for n in names) or error.message
    shown = json.dumps(error.instance)[:40]
    raise BadInput(f"{what}: field {field or '(the whole record)'} is {shown}; valid: {valid} (the file as mapush "
                   "wrote it)")  # fmt: skip


@functools.cache
def _validator(schema_text: str) -> Draft202012Validator:
    schema = json.loads(schema_text)
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)
