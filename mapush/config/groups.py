"""The config tree (`CONF_DIR`), its groups (task, level, rules, ...) and their options, and the dirs that
`hydra.searchpath` adds. The other modules read `groups.CONF_DIR` when called, so that pointing it at a copy of the
tree (`mapush.config.CONF_DIR = ...`, as tests do) points them all there."""

from __future__ import annotations

import functools
import importlib.util
import os
from pathlib import Path

from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig, OmegaConf

from mapush.errors import BadInput

CONF_DIR = Path(os.environ.get("MAPUSH_CONF_DIR", Path(__file__).resolve().parent.parent / "conf"))
"""The `mapush/conf/` tree: package data, so a checkout, an editable install and a wheel all compose alike."""

GROUPS = ("task", "level", "rules", "lowlevel", "reward", "algo", "critic", "debug")


def group_file(group: str, name: str) -> DictConfig:
    """One config file of a group as written, not composed (e.g. experiment, scale: its sweep axes and budgets).
    Read only: each file is parsed once while it stays as it is (a table reads the experiments' files dozens of
    times); copy it (`OmegaConf.to_container`) to change it."""
    path = CONF_DIR / group / f"{name}.yaml"
    found = os.stat(path)
    return _parsed(str(path), found.st_size, found.st_mtime_ns)


@functools.lru_cache(maxsize=256)
def _parsed(path: str, _size: int, _mtime_ns: int) -> DictConfig:
    cfg = OmegaConf.load(path)
    OmegaConf.set_readonly(cfg, True)
    return cfg


def group_options(group: str, extra_dirs: list[Path] = ()) -> list[str]:
    """The config files of a group, by name (e.g. task -> cuboid, cylinder, ocb_cuboid, tblock), in the package's
    config dir and in `extra_dirs` (those that `hydra.searchpath` adds)."""
    return sorted({p.stem for d in (CONF_DIR, *extra_dirs) for p in (Path(d) / group).glob("*.yaml")})


def search_dirs(overrides: list[str]) -> list[Path]:
    """The config dirs that a `hydra.searchpath=[...]` override adds, where configs of your own live (a task
    file at `<dir>/task/NAME.yaml`): `file://` paths, plain paths and `pkg://` packages (an installed plugin)."""
    dirs = []
    for override in overrides:
        key, sep, _ = override.partition("=")
        if key != "hydra.searchpath" and key.lstrip("+~") == "hydra.searchpath":  # Hydra reads only that spelling
            raise BadInput(f"{override!r} is not read by Hydra; valid: hydra.searchpath=[file:///DIR]")
        if not sep or key != "hydra.searchpath":
            continue
        parsed = OverridesParser.create().parse_override(override).value()
        dirs += [_search_dir(str(entry)) for entry in (parsed if isinstance(parsed, list) else [parsed])]
    return dirs


def _search_dir(entry: str) -> Path:
    """The dir of one searchpath entry: `file://DIR` or `DIR` as it is, `pkg://PACKAGE/SUB` in the installed
    package (BadInput if it is not installed)."""
    scheme, _, where = entry.rpartition("://")
    if scheme != "pkg":
        return Path(where)
    name, _, sub = where.partition("/")
    try:
        spec = importlib.util.find_spec(name)
    except ModuleNotFoundError:  # a parent package that is not installed
        spec = None
    if spec is None or not spec.submodule_search_locations:
        raise BadInput(f"hydra.searchpath names pkg://{where}, not an installed package; valid: file://DIR")
    return Path(next(iter(spec.submodule_search_locations))) / sub


def check_groups(overrides: list[str]) -> None:
    """Refuse a `group=name` override whose file is in no config dir, naming the group's options (Hydra's own
    message names neither them nor `hydra.searchpath`)."""
    extra = search_dirs(overrides)
    for override in overrides:
        key, sep, value = override.lstrip("+~").partition("=")
        options = group_options(key, extra) if key in GROUPS else []
        if sep and key in GROUPS and value not in options and not (key == "debug" and value == "null"):
            where = f"in mapush and {', '.join(map(str, extra))}" if extra else "add yours with hydra.searchpath"
            raise BadInput(f"unknown {key} {value!r}; valid: {', '.join(options)} ({where})")
