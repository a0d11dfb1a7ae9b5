"""The Typer app every `mapush` command registers on, and what the commands' signatures share: the config groups
in their help, the settings that pass Hydra overrides through."""

from __future__ import annotations

import os
from importlib import metadata

import typer

from mapush.trust import TRUST_ENV

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help=(
        "Hierarchical multi-agent quadruped pushing (MAPush) on MuJoCo and rsl-rl.\n\n"
        "locomotion: the low level, a Go1 walking to velocity commands (mapush train level=locomotion; one ships)\n"
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
