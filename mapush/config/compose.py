"""Composing `conf/config.yaml` (a run) or `conf/sweep.yaml` (a sweep job) with Hydra overrides, remembered per
process, and reading values off a composed config."""

from __future__ import annotations

import copy
import os
from pathlib import Path

from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import DictConfig, OmegaConf

from mapush.config import groups
from mapush.config.groups import check_groups, search_dirs
from mapush.errors import BadInput, first_line
from mapush.schema import check_config, task_weight_names

COMPOSED_KEPT = 256
"""How many composed configs a process keeps (a few MB): more than the main table's plan composes."""
_COMPOSED: dict[tuple, tuple[tuple, DictConfig]] = {}
"""Configs this process composed, by overrides and config name, with the config files' stamp they were composed
from: a sweep plans each stage more than once, and Hydra reads every file anew each time (about 0.4 s)."""


def run_dir_override(override: str) -> str:
    """Hydra's `hydra.run.dir=DIR` (a Hydra app's run dir) is mapush's `train.run_dir=DIR`."""
    key, sep, value = override.partition("=")
    return f"train.run_dir={value}" if sep and key.lstrip("+") == "hydra.run.dir" else override


def unknown_key_message(base: DictConfig, full_key: str) -> str:
    """The refusal of a key `base` lacks, naming the keys its parent has."""
    parent, _, _leaf = full_key.rpartition(".")
    node = OmegaConf.select(base, parent) if parent else base
    valid = ", ".join(str(k) for k in node) if isinstance(node, DictConfig) else "(none)"
    where = f" under '{parent}'" if parent else ""
    return f"unknown config key {full_key!r}; valid keys{where}: {valid}"


def compose_config(
    overrides: list[str] | tuple[str, ...] = (), config_name: str = "config", hydra: bool = False
) -> DictConfig:
    """Compose `conf/<config_name>.yaml` (a run: `config`; a sweep job: `sweep`) with Hydra overrides.

    Every mistake (an unknown key or group, a value of the wrong type or range: `schema.RULES`) is a BadInput
    naming the valid choices. `hydra=True` keeps the `hydra` node (e.g. the sweep dir).
    """
    overrides = [run_dir_override(o) for o in overrides] if config_name == "config" else list(overrides)
    check_groups(overrides)
    key, files = (tuple(overrides), config_name), _files_stamp(search_dirs(overrides))
    if not hydra and _COMPOSED.get(key, (None,))[0] == files:
        return copy.deepcopy(_COMPOSED[key][1])
    cfg = _hydra_compose(overrides, config_name, hydra)
    check_config(cfg, task_weight_names([groups.CONF_DIR, *search_dirs(overrides)]))  # before anything is built
    task = [o.split("=", 1)[1] for o in overrides if o.lstrip("+").startswith("task=")][-1:]
    if config_name == "config" and task and cfg.task.name != task[0] and not any("task.name=" in o for o in overrides):
        # a task file copied from another that kept its `name:` would be trained, swept and filed as that one
        raise BadInput(f"task={task[0]}: its file says name: {cfg.task.name}; valid: name: {task[0]} (the file's)")
    if not hydra:
        _COMPOSED[key] = (files, copy.deepcopy(cfg))
        while len(_COMPOSED) > COMPOSED_KEPT:
            _COMPOSED.pop(next(iter(_COMPOSED)))  # the oldest: a long sweep's worker composes job after job
    return cfg


def _hydra_compose(overrides: list[str], config_name: str, hydra: bool) -> DictConfig:
    """Hydra's compose of the package's config dir; its errors (several types, all the user's override mistakes)
    as one BadInput, an unknown key's naming the keys its parent has."""
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(groups.CONF_DIR), version_base="1.3"):
        try:
            return compose(config_name=config_name, overrides=overrides, return_hydra_config=hydra)
        except Exception as err:
            full_key = getattr(err.__cause__, "full_key", None)
            if full_key and "not in struct" in str(err.__cause__):
                base = compose(config_name=config_name, overrides=[o for o in overrides if full_key not in o])
                raise BadInput(unknown_key_message(base, str(full_key))) from None
            raise BadInput(f"bad override: {first_line(err)}") from None


def _files_stamp(extra_dirs: list[Path]) -> tuple:
    """Every config file's path, size and modification time: a composed config stands while this is the same."""
    paths = sorted(p for d in (groups.CONF_DIR, *extra_dirs) for p in Path(d).rglob("*.yaml"))
    stats = [p.stat() for p in paths]
    return tuple((str(p), s.st_size, s.st_mtime_ns) for p, s in zip(paths, stats, strict=True))


def to_plain(cfg: DictConfig) -> dict:
    """The config as plain, resolved Python containers (what rsl-rl and the env receive)."""
    return OmegaConf.to_container(cfg, resolve=True)


def sim_threads(cfg: DictConfig | dict) -> int:
    """The MuJoCo threads a config steps its batch with: `sim.nthread`, where 0 means every core of this machine."""
    return int(cfg["sim"]["nthread"]) or os.cpu_count() or 1


def env_steps_per_iteration(cfg: dict) -> int:
    """50 Hz control steps of one env that one PPO iteration trains on (a high-level decision holds several)."""
    per_decision = int(cfg["level"].get("decision_steps", 1))
    return int(cfg["num_envs"]) * int(cfg["algo"]["num_steps_per_env"]) * per_decision
