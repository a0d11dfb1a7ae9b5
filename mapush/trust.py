"""Configs are data: which code a config may name.

A run dir's `config.yaml` is shared between researchers, and opening one must not run code of its choosing. So
the code a config names (a term's `func`, rsl-rl's `class_name`) is imported only from trusted modules: mapush's
term and learner packages, rsl-rl, the modules of installed `mapush.plugins` entry points, and the modules the
user trusts on the command line (`mapush --trust MODULE`, or `MAPUSH_TRUST=a,b`). Anything else is refused with
one line before it is imported.
"""

from __future__ import annotations

import os
from importlib import metadata

from mapush.errors import BadInput

TRUSTED_MODULES = ("mapush.rewards", "mapush.envs", "mapush.lowlevel", "mapush.rl", "mapush.logging", "rsl_rl")
"""Packages whose functions and classes any config may name (with their submodules)."""
TRUST_ENV = "MAPUSH_TRUST"
"""Comma-separated modules the user trusts as well (`mapush --trust MODULE` sets it for the command's processes)."""
PLUGIN_GROUP = "mapush.plugins"
"""Entry-point group of installed plugins: each entry point's module (and its submodules) is trusted."""


def trusted_modules() -> tuple[str, ...]:
    """Every module root a config may name code from, today."""
    user = [name.strip() for name in os.environ.get(TRUST_ENV, "").split(",") if name.strip()]
    plugins = [entry.value.partition(":")[0].strip() for entry in metadata.entry_points(group=PLUGIN_GROUP)]
    return (*TRUSTED_MODULES, *plugins, *user)


def check_trusted(key: str, path: object) -> None:
    """BadInput unless `path` (`module:attr`, `module.attr`, or a bare rsl-rl class name) names trusted code."""
    if not isinstance(path, str):
        raise BadInput(f"{key}={path!r} is not valid; valid: a string naming a function or class")
    module = path.partition(":")[0] if ":" in path else path.rpartition(".")[0]
    if not module:
        return  # a bare name: rsl-rl looks it up among its own classes only
    trusted = trusted_modules()
    if not any(module == root or module.startswith(f"{root}.") for root in trusted):
        raise BadInput(
            f"{key}={path!r} names code outside the trusted modules, refused (a config is data); valid: code in "
            f"{', '.join(trusted)}, or trust its module with `mapush --trust {module.split('.')[0]} ...`"
        )


def check_class_names(section: str, node: object) -> None:
    """`check_trusted` for every `class_name` in a config section (rsl-rl's algorithm, actor, critic, ...)."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "class_name":
                check_trusted(f"{section}.class_name", value)
            else:
                check_class_names(f"{section}.{key}", value)
