"""SHA-256 digests of exported and shipped weight files, recorded when written and checked when loaded.

A weight file altered on disk (a bad copy, a bit flip, an edit) still loads, and its policy then fails silently
(0 % success). So each exported (`policy.pt`, `policy.onnx`) and shipped (those and the slim checkpoint) weight
file has its digest in `sha256.json` beside it, and loading one that no longer matches is refused. A file with no
digest recorded (made before digests were) loads as before.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from mapush.atomic import write_json
from mapush.errors import BadInput

SUMS_FILE = "sha256.json"
"""`{file name: sha256 hex digest}` of the weight files in the same dir."""
WEIGHT_SUFFIXES = (".pt", ".onnx")


def sha256(path: Path) -> str:
    """The hex SHA-256 digest of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def recorded(directory: Path) -> dict[str, str]:
    """The digests recorded in `directory` (none: {}); BadInput naming a sums file that is not one."""
    path = Path(directory) / SUMS_FILE
    if not path.is_file():
        return {}
    try:
        sums = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError):
        sums = None
    if not isinstance(sums, dict) or not all(isinstance(v, str) for v in sums.values()):
        raise BadInput(f"{str(path)!r} is not a digest record; valid: {{file name: sha256 hex}}, as mapush writes")
    return sums


def record(directory: Path, names: list[str]) -> Path:
    """Record the digests of the files `names` in `directory` (beside those recorded already)."""
    directory = Path(directory)
    try:
        sums = recorded(directory)
    except BadInput:  # a damaged record is rewritten whole
        sums = {}
    sums |= {name: sha256(directory / name) for name in names}
    return write_json(directory / SUMS_FILE, dict(sorted(sums.items())))


def forget(directory: Path, names: list[str]) -> None:
    """Drop the digests of `names` (files about to be rewritten): a cut rewrite then loads as an old file would."""
    sums = recorded(directory)
    if any(name in sums for name in names):
        write_json(Path(directory) / SUMS_FILE, {k: v for k, v in sums.items() if k not in names})


def weight_files(directory: Path) -> list[str]:
    """The names of the weight files in `directory` (checkpoints and exported policies)."""
    return sorted(p.name for p in Path(directory).iterdir() if p.suffix in WEIGHT_SUFFIXES and p.is_file())


def record_weights(directory: Path) -> Path:
    """Record the digest of every weight file in `directory` (a shipped slim run dir: `mapush ship`, or to give
    the files shipped before digests theirs)."""
    return record(directory, weight_files(directory))


def verify(path: Path) -> None:
    """BadInput naming `path` if its digest differs from the one recorded beside it."""
    path = Path(path)
    expected = recorded(path.parent).get(path.name)
    if expected is not None and path.is_file() and sha256(path) != expected:
        raise BadInput(
            f"{str(path)!r} does not match its sha256 in {SUMS_FILE} (altered on disk since it was written); "
            "valid: the file as mapush wrote it (export or ship it again)"
        )
