"""A sweep's plan, remembered: every job's composed config and planned stages, kept on disk under the key of all
that composing them reads, so that a dry run (or a second launch) of an unchanged experiment answers in seconds.

Composing and checking a job's stages is Hydra reading every config file anew (about half a second a config: a
minute for the main table's 36 jobs). What that yields is a function of the command line's overrides, the mapush
package's configs and the code that composes and plans a job (`archive.composing_digest`, with Hydra's and
OmegaConf's versions), the config files of any `hydra.searchpath` dir (its groups' YAML), the environment
variables those configs read (`${oc.env:NAME}`) and mapush's own (`MAPUSH_*`), the trusted modules (a config
naming other code is refused when checked) and this machine's core count (`${cores:}`). The memo's file is named
by the hash of all of these, so a change to any of them is a miss and the plan is composed (and checked) again.
What a hit skips is the check of the stages' configs against their envs (`sweep_axes._check_jobs`): a term
function of yours that changed since is met when the job trains. The memo lives in the user's cache dir
(`$XDG_CACHE_HOME/mapush/plans`, or `MAPUSH_CACHE`), outside run dirs; each caller gets its own copy.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from mapush import config
from mapush.atomic import write_json
from mapush.config import search_dirs
from mapush.experiments.archive import composing_digest, files_digest
from mapush.experiments.stage_plan import PlannedStage
from mapush.trust import trusted_modules

CACHE_ENV = "MAPUSH_CACHE"
"""Where mapush keeps what it can compute again (default `$XDG_CACHE_HOME/mapush`, else `~/.cache/mapush`)."""

FORMAT = 1
"""The memo file's layout; another is a miss."""

Plan = list[tuple[list[str], DictConfig, list[PlannedStage]]]
"""Each job of a sweep: its axis overrides, its composed job config and its planned stages, in sweep order."""


def cache_dir() -> Path:
    """mapush's cache dir for this user."""
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mapush"


def plan_key(full: list[str]) -> str:
    """The hash of everything a sweep's plan depends on (module docstring)."""
    dirs = [Path(config.CONF_DIR), *map(Path, search_dirs(full))]  # the package's configs (or their stand-in), yours
    found = [(d, sorted(_config_files(d))) for d in dirs if d.is_dir()]
    searched = [files_digest(paths, d) for d, paths in found]
    read = sorted({name for _, paths in found for path in paths for name in ENV_READ.findall(path.read_text())})
    env = [f"{name}={os.environ.get(name)}" for name in read]
    env += sorted(f"{k}={v}" for k, v in os.environ.items() if k.startswith("MAPUSH_") and k != CACHE_ENV)
    parts = [f"format {FORMAT}", composing_digest(), *searched, json.dumps(full), ",".join(trusted_modules())]
    parts += [*env, f"cores {os.cpu_count()}"]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


ENV_READ = re.compile(r"oc\.env\s*:\s*([A-Za-z_][A-Za-z0-9_]*)")
"""An environment variable a config reads (`${oc.env:NAME}`, `${oc.env:NAME,default}`)."""


def _config_files(root: Path) -> list[Path]:
    """The YAML that Hydra can compose from a config dir: its top level and its groups' dirs (those the package's
    config tree has), not whatever else lies below it (a search path of `.` holds run dirs)."""
    groups = {p.name for p in Path(config.CONF_DIR).iterdir() if p.is_dir()}
    return [p for p in root.glob("*.yaml")] + [p for g in sorted(groups) for p in (root / g).rglob("*.yaml")]


def _path(full: list[str]) -> Path:
    return cache_dir() / "plans" / f"{plan_key(full)}.json"


_READ: dict[str, str | None] = {}
"""The memo files this process read or wrote, by key, as their text (None: none that reads back as a plan): the
sweep's check and its plan ask for the same one, and each gets objects of its own built from it."""


def known(full: list[str]) -> bool:
    """Whether a plan is remembered for `full` (as `sweep_axes.sweep_overrides` returns it)."""
    return _text(plan_key(full)) is not None


def recall(full: list[str]) -> Plan | None:
    """The plan remembered for `full`, as objects of the caller's own, or None (a miss)."""
    text = _text(plan_key(full))
    return None if text is None else _plan(text)


def _text(key: str) -> str | None:
    if key not in _READ:
        try:
            text = (cache_dir() / "plans" / f"{key}.json").read_text()
        except OSError:
            text = None
        _READ[key] = text if text is not None and _well_formed(text) else None
    return _READ[key]


def _well_formed(text: str) -> bool:
    """Whether a memo file reads as a plan: every job its axes, a config mapping and stages of every field."""
    fields = set(PlannedStage._fields)
    try:
        jobs = json.loads(text)["jobs"]
        return isinstance(jobs, list) and all(
            isinstance(job["combo"], list)
            and isinstance(job["cfg"], dict)
            and all(isinstance(stage, dict) and set(stage) == fields for stage in job["stages"])
            for job in jobs
        )
    except (ValueError, KeyError, TypeError):
        return False


def _plan(text: str) -> Plan | None:
    try:
        record = json.loads(text)
        return [
            (job["combo"], _job_config(job["cfg"]), [_stage(stage) for stage in job["stages"]])
            for job in record["jobs"]
        ]
    except Exception:  # cut, altered or of another layout: a cache, so composed again, whatever it holds
        return None


def remember(full: list[str], plan: Plan) -> None:
    """Keep `plan` under `full`'s key; a cache dir that cannot be written keeps nothing (the plan still stands)."""
    record = {
        "jobs": [
            {
                "combo": combo,
                "cfg": OmegaConf.to_container(cfg, resolve=False),  # interpolations kept, as composed
                "stages": [{**stage._asdict(), "shape": list(stage.shape)} for stage in planned],
            }
            for combo, cfg, planned in plan
        ]
    }
    path = _path(full)
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_json(path, record)
    _READ[path.stem] = json.dumps(record)


def _job_config(container: dict) -> DictConfig:
    """A job's config as `compose_config` returns it: struct mode on, so that a wrong key still fails."""
    if not isinstance(container, dict):
        raise ValueError(f"a job's config is a mapping, not {type(container).__name__}")
    cfg = OmegaConf.create(container)
    OmegaConf.set_struct(cfg, True)
    return cfg


def _stage(record: dict) -> PlannedStage:
    return PlannedStage(**{**record, "shape": tuple(record["shape"])})
