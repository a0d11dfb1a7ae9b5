"""The Typer app every `mapush` command registers on, and what the commands share."""

from __future__ import annotations

import os
from importlib import metadata
from pathlib import Path

import typer

from mapush.errors import BadInput
from mapush.trust import TRUST_ENV

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help=(
        "Hierarchical multi-agent quadruped pushing (MAPush) on MuJoCo and rsl-rl.\n\n"
        "low: Go1 locomotion (mapush train level=low; a trained one ships)\n"
        "mid: pushing the object to subgoals (mapush train; level=mid by default)\n"
        "high: subgoals along a planned path (mapush train level=high mid=RUN_DIR)\n\n"
        "mapush sweep trains a method's levels in turn and evaluates them (the tables)."
    ),
)


def _print_version(asked: bool) -> None:
    if asked:
        print(f"mapush {metadata.version('mapush')}")
        raise typer.Exit()


@app.callback()
def common(
    trust: list[str] = typer.Option(
        [],
        "--trust",
        metavar="MODULE",
        help="Let configs name functions and classes of MODULE (repeatable); by default only mapush's and rsl-rl's.",
    ),
    version: bool = typer.Option(
        False, "--version", help="Print mapush's version and exit.", is_eager=True, callback=_print_version
    ),
) -> None:
    """Hierarchical multi-agent quadruped pushing (MAPush) on MuJoCo and rsl-rl."""
    if trust:  # in the environment, so that sweep workers and launched jobs trust the same modules
        earlier = [m for m in os.environ.get(TRUST_ENV, "").split(",") if m]
        os.environ[TRUST_ENV] = ",".join([*earlier, *trust])


def groups_epilog() -> str:
    """The config groups and their options, for the help of the commands that take Hydra overrides."""
    from mapush.config import GROUPS, group_options

    choices = "; ".join(f"{group}={'|'.join(group_options(group))}" for group in GROUPS)
    return f"Config groups: {choices}. Any key: key=value (mapush train --cfg job prints them all; mapush list)."


PASS_THROUGH = {"allow_extra_args": True, "ignore_unknown_options": True}
"""Commands that take Hydra overrides (`key=value`) after their own options."""


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
