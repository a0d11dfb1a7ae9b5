"""The Typer app every `mapush` command registers on, and what the commands share."""

from __future__ import annotations

import typer

from mapush.errors import BadInput

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Hierarchical multi-agent quadruped pushing (MAPush) on MuJoCo and rsl-rl.",
)
PASS_THROUGH = {"allow_extra_args": True, "ignore_unknown_options": True}
"""Commands that take Hydra overrides (`key=value`) after their own options."""


def number_list(text: str, flag: str, kind: type = int, minimum: float = 0) -> list:
    """`0,1,2` -> [0, 1, 2] (of `kind`, each >= `minimum`); BadInput naming the flag otherwise."""
    name = "integers" if kind is int else "numbers"
    try:
        values = [kind(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or min(values) < minimum:
        raise BadInput(f"{flag} {text!r} is not valid; valid: comma-separated {name} >= {minimum:g}, e.g. 1,2,3")
    return values
