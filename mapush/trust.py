"""Configs are data: which code a config may name.

A run dir's `config.yaml` is shared between researchers, and opening one must not run code of its choosing. So
the code a config names (a term's `func`, rsl-rl's `class_name`) is imported only from trusted modules: mapush's
term and learner packages, rsl-rl, the modules of installed `mapush.plugins` entry points, and the modules the
user trusts on the command line (`mapush --trust MODULE`, or `MAPUSH_TRUST=a,b`). Anything else is refused with
one line before it is imported.
"""

from __future__ import annotations

import importlib
import os
import re
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


def _is_trusted(module: str, trusted: tuple[str, ...]) -> bool:
    return any(module == root or module.startswith(f"{root}.") for root in trusted)


def check_trusted(key: str, path: object) -> None:
    """BadInput unless `path` names trusted code: `module:Name` (one name after the colon, whose object is defined
    in a trusted module, so that no trusted module can lend out a name it imported) or a bare rsl-rl class name."""
    if not isinstance(path, str):
        raise BadInput(f"{key}={path!r} is not valid; valid: a string naming a function or class")
    if "${" in path:
        raise BadInput(f"{key}={path!r}: an interpolation cannot name code, refused; valid: module:Name")
    module = path.partition(":")[0] if ":" in path else path.rpartition(".")[0]
    if not module:
        return  # a bare name: rsl-rl looks it up among its own classes only
    trusted = trusted_modules()
    if not _is_trusted(module, trusted):
        raise BadInput(
            f"{key}={path!r} names code outside the trusted modules, refused (a config is data); valid: code in "
            f"{', '.join(trusted)}, or trust its module with `mapush --trust {module.split('.')[0]} ...`"
        )
    name = path.partition(":")[2]
    if ":" not in path or not name.isidentifier():
        raise BadInput(f"{key}={path!r} is refused; valid: module:Name, one name after the colon")
    try:
        found = getattr(importlib.import_module(module), name, None)
    except ImportError:
        return  # the caller names the module that does not import
    owner = getattr(found, "__module__", None)
    if found is not None and not (isinstance(owner, str) and _is_trusted(owner, trusted)):
        raise BadInput(f"{key}={path!r} is code of {owner!r}, lent by {module}; refused (a config is data)")


QUALIFIED = re.compile(r"^[A-Za-z_]\w*(?:[.:][A-Za-z_]\w*)+$")
"""A string that rsl-rl would resolve to code (`module:Name`, `package.module.Name`)."""


def check_class_names(section: str, node: object, resolved: bool = True) -> None:
    """`check_trusted` for every `class_name` in a config section (rsl-rl's algorithm, actor, critic, ...) and, in
    a `resolved` section, for every other string that rsl-rl could resolve to code (a symmetry function, say).
    Unresolved, only `class_name`s are checked: none may be an interpolation."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "class_name" or (resolved and isinstance(value, str) and QUALIFIED.match(value)):
                check_trusted(f"{section}.{key}", value)
            else:
                check_class_names(f"{section}.{key}", value, resolved)
    elif isinstance(node, list):
        for k, value in enumerate(node):
            check_class_names(f"{section}[{k}]", value, resolved)
