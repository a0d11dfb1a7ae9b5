"""What the commands share in reading their arguments: lists of numbers and seeds, paths to write files at."""

from __future__ import annotations

from pathlib import Path

from mapush.errors import BadInput


def number_list(text: str, flag: str, kind: type = int, minimum: float = 0, maximum: float | None = None) -> list:
    """`0,1,2` -> [0, 1, 2] (of `kind`, each in [`minimum`, `maximum`]); BadInput naming the flag otherwise."""
    name = "integers" if kind is int else "numbers"
    try:
        values = [kind(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or min(values) < minimum or (maximum is not None and max(values) > maximum):
        low, high = (f"{kind(x):g}" if kind is float else str(int(x)) for x in (minimum, maximum or 0))
        span = f">= {low}" if maximum is None else f"in [{low}, {high}]"
        raise BadInput(f"{flag} {text!r} is not valid; valid: comma-separated {name} {span}, e.g. 1,2,3")
    return values


def seeds_of(text: str, flag: str = "--seeds") -> list[int]:
    """`0,1` -> [0, 1]: seeds, each in [0, `SEED_MAX`] (what numpy seeds with); BadInput naming the flag otherwise."""
    from mapush.schema import SEED_MAX

    return number_list(text, flag, maximum=SEED_MAX)


def output_file(path: Path, flag: str) -> Path:
    """`path` for a command to write a file at; BadInput unless nothing is there or a plain file is (a dir, a
    symlink, whose target would be written through, or a device is refused), under dirs."""
    shown = _no_link_under_dirs(path, flag, "a plain file path (mapush writes no file through a link)")
    if path.is_dir():
        raise BadInput(f"{shown} is a directory; valid: a file path, not a dir")
    if path.exists() and not path.is_file():
        raise BadInput(f"{shown} is not a plain file (a device or pipe); valid: a file path")
    return path


def output_dir(path: Path, flag: str) -> Path:
    """`path` for a command to write its files into; BadInput unless nothing is there or a dir (not a symlink to
    one, whose target would be written through), under dirs."""
    shown = _no_link_under_dirs(path, flag, "a plain dir path (mapush writes no files through a link)")
    if path.exists() and not path.is_dir():
        raise BadInput(f"{shown} is a file; valid: a directory (or a path not taken yet), not a file")
    return path


def _no_link_under_dirs(path: Path, flag: str, valid: str) -> str:
    """`flag 'path'` as a message names it; BadInput when `path` is a symlink (`valid` says what is) or lies under
    a file (`_under_dirs`)."""
    shown = f"{flag} {str(path)!r}"
    if path.is_symlink():
        raise BadInput(f"{shown} is a symlink; valid: {valid}")
    _under_dirs(path, shown)
    return shown


def _under_dirs(path: Path, shown: str) -> None:
    """BadInput when the nearest existing parent of `path` is not a dir (a file where a dir must go)."""
    parent = next((p for p in path.absolute().parents if p.exists()), None)
    if parent is not None and not parent.is_dir():
        raise BadInput(f"{shown}: {str(parent)!r} is a file, not a dir; valid: a path whose parents are dirs")
