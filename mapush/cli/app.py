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


def int_list(text: str, flag: str) -> list[int]:
    try:
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise BadInput(f"{flag} {text!r} must be comma-separated integers, e.g. 0,1,2,3") from None
