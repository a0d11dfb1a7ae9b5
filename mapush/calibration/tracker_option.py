"""The calibrated tracker as a `lowlevel=` option of its own: `OUT/lowlevel/<name>.yaml` in calibrate's output dir,
named with that dir on Hydra's search path. The package's `conf/lowlevel/tracker.yaml` is its base, read as data
and never written: an installed package stays as it shipped, and runs name the tracker they train on.
"""

from __future__ import annotations

import datetime
import json
import re
import shlex
from pathlib import Path

from omegaconf import OmegaConf

from mapush import config
from mapush.atomic import write_text
from mapush.config import group_options
from mapush.errors import BadInput

DEFAULT_NAME = "tracker_calibrated"
"""The option calibrate writes unless `--name` says otherwise."""
NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")
"""What a `lowlevel=` option's name may be: one word of a file name, as `schema.NAMES` wants of `lowlevel.name`."""
PLAIN_PATH = re.compile(r"[A-Za-z0-9_./+-]+")
"""A path Hydra's override grammar reads unquoted inside a list."""


def default_config_path() -> Path:
    """The package's tracker config (`conf/lowlevel/tracker.yaml`): the base of every calibrated tracker."""
    return config.CONF_DIR / "lowlevel" / "tracker.yaml"


def check_name(name: str) -> None:
    """Refuse an option name Hydra or a run dir cannot carry, or one the package ships: Hydra reads the package's
    config dir before the search path, so `lowlevel=tracker` would compose the package's file, not the fit."""
    if not NAME.fullmatch(name):
        raise BadInput(f"--name {name!r}: valid: letters, digits, - and _ (1 to 64), e.g. {DEFAULT_NAME}")
    if name in group_options("lowlevel"):
        shipped = f"mapush ships lowlevel={name}, which would be composed instead"
        raise BadInput(f"--name {name}: {shipped}; valid: another name, e.g. {DEFAULT_NAME}")


def write_tracker_option(out_dir: Path, name: str, fitted: dict, source: str) -> Path:
    """Write `out_dir/lowlevel/<name>.yaml`: the package's tracker config with the `fitted` values, named `name` on
    the tracker's backend (as `go1_strong` is a Go1), dumped from data; a comment says what it was calibrated on."""
    base = OmegaConf.to_container(OmegaConf.load(default_config_path()))
    tracker = {"name": name, "backend": "tracker"} | {k: v for k, v in base.items() if k not in ("name", "backend")}
    tracker |= json.loads(json.dumps(fitted))  # plain floats (a fit gives numpy's)
    keys, today = ", ".join(fitted) or "nothing", datetime.date.today().isoformat()
    header = (
        f"# lowlevel={name}: the package's tracker ({default_config_path().name}) with {keys}\n"
        f"# calibrated against {source}, {today}, by `mapush calibrate` (every measurement:\n"
        "# ../calibration.json). Use it with the dir above lowlevel/ on Hydra's search path:\n"
        f"# {use_line(name, out_dir).removeprefix('use it: ')}\n"
    )
    path = Path(out_dir) / "lowlevel" / f"{name}.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text(path, header + OmegaConf.to_yaml(OmegaConf.create(tracker)))


def searchpath_override(out_dir: Path) -> str:
    """`hydra.searchpath=[file:///OUT]`, the dir absolute (quoted for Hydra where its grammar needs it), so that a
    `lowlevel=` option written under `OUT/lowlevel/` composes from any working dir."""
    where = f"file://{Path(out_dir).resolve()}"
    if not PLAIN_PATH.fullmatch(where.removeprefix("file://")):
        where = "'" + where.replace("\\", "\\\\").replace("'", "\\'") + "'"
    return f"hydra.searchpath=[{where}]"


def use_line(name: str, out_dir: Path) -> str:
    """The one line calibrate prints: the command that trains on the calibrated tracker, quoted for a shell."""
    return f"use it: mapush train lowlevel={name} {shlex.quote(searchpath_override(out_dir))}"
