"""Overrides in Hydra's grammar: naming them, translating Hydra's spellings, and applying them to a saved config
(an existing run's eval), checked as a composed config is."""

from __future__ import annotations

import copy
import re

from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig, OmegaConf

from mapush.config import groups
from mapush.config.compose import compose_config, unknown_key_message
from mapush.config.groups import GROUPS, check_groups
from mapush.errors import BadInput, first_line
from mapush.rules import rule_keys
from mapush.schema import check_config

SWAPPABLE_GROUPS = ("task", "level", "rules", "lowlevel", "reward")
"""Groups whose file can replace a saved run's node in `apply_overrides`."""


def overrides_name(overrides: list[str]) -> str:
    """A file-name tag for an evaluation's overrides (`task.num_agents=3` -> `task.num_agents-3`); '' for none."""
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", "_".join(overrides)).strip("-")


def apply_overrides(cfg: DictConfig, overrides: list[str]) -> DictConfig:
    """Apply overrides to a saved run config (eval of an existing run), parsed by Hydra's own override grammar as
    `mapush train` parses them: `key=value`, `+key=value` (a new key), `++key=value`, `~key` and `group=name`
    (a group of `SWAPPABLE_GROUPS`); values and ranges are checked as for a run."""
    cfg = cfg.copy()
    OmegaConf.set_struct(cfg, False)  # a freshly composed config is in struct mode; a loaded one is not
    parser = OverridesParser.create()
    for text in overrides:
        try:
            override = parser.parse_override(text)
        except Exception as err:  # Hydra's grammar errors: the user's typing
            raise BadInput(f"bad override {text!r} ({first_line(err)}); valid: key=value") from None
        if override.is_sweep_override():
            raise BadInput(f"override {text!r} is a sweep; valid: one value per key (sweeps: mapush sweep)")
        if override.key_or_group in GROUPS:
            _swap_group(cfg, override.key_or_group, str(override.value()))
        else:
            _set_key(cfg, override)
    check_config(cfg)
    return cfg


def _with_rules(level: DictConfig, rules: str) -> DictConfig:
    """A saved run's level node under the rule set `rules`: every key some rule set sets at its level
    (`rules.rule_keys`: the episode endings, what a fallen robot does, the exceptions) as the level composed with
    `rules` has it (its file, the files it extends, the rule set's), the rest as the run had it. Merging the rule
    set's file alone would keep what the run's own set had changed: mapush's set changes nothing of the level's
    file, so `rules=strict` on a run trained under the original's kept the original's endings."""
    name = str(level.name)
    composed = compose_config([f"level={name}", f"rules={rules}"]).level  # interpolations left to the run's config
    level = copy.deepcopy(level)
    for key in rule_keys(groups.CONF_DIR, name):
        if key in composed:
            level[key] = copy.deepcopy(composed[key])
        elif key in level:
            del level[key]
    level.rules = rules
    return level


def _swap_group(cfg: DictConfig, group: str, name: str) -> None:
    """`group=name` on a saved config: the group's file replaces its node (the rules: merged into the level's)."""
    if group not in SWAPPABLE_GROUPS:
        raise BadInput(f"group {group!r} cannot change for an existing run; valid: {', '.join(SWAPPABLE_GROUPS)}")
    check_groups([f"{group}={name}"])
    if group == "rules":  # the rules at the run's level, as composing the level with them gives them
        cfg.level = _with_rules(cfg.level, name)
    else:
        cfg[group] = OmegaConf.load(groups.CONF_DIR / group / f"{name}.yaml")


def _set_key(cfg: DictConfig, override) -> None:
    """`key=value`, `+key=value`, `++key=value` or `~key` on a saved config, refused as Hydra refuses them."""
    key, value = override.key_or_group, override.value()
    exists = OmegaConf.select(cfg, key, default="<missing>") != "<missing>"
    if override.is_delete():
        if not exists:
            raise BadInput(unknown_key_message(cfg, key))
        parent, _, leaf = key.rpartition(".")
        node = OmegaConf.select(cfg, parent) if parent else cfg
        node.pop(leaf)
    elif override.is_add() and exists:
        raise BadInput(f"config key {key!r} already exists; valid: {key}=VALUE")
    elif not exists and not (override.is_add() or override.is_force_add()):
        raise BadInput(unknown_key_message(cfg, key))
    else:
        OmegaConf.update(cfg, key, value, merge=False, force_add=True)
