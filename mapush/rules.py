"""The rule sets (`conf/rules/`): what ends an episode at each level, the original's (`rules=original`) or mapush's
(`rules=strict`, the default). A rule set is one file per level, `conf/rules/level/<rules>_<level>.yaml`, merged into
the level node; docs/fidelity.md, "Rules: what ends an episode", gives each rule's source."""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from mapush.errors import BadInput

ORIGINAL_COLLISION_M = {"tblock": 0.27}
"""m; the original's base-distance collision threshold per task where it was not 0.25 (its task configs)."""


def original_collision_m(task: str) -> float:
    """The distance (m) between two robot bases at which the original ended a push on task `task`: 0.25 m, 0.27 m
    on the T-block (its task configs' `termination.collision_kwargs`); the resolver `${original_collision_m:...}`."""
    return ORIGINAL_COLLISION_M.get(str(task), 0.25)


def rules_at_level(conf_dir: Path, rules: str, level: str) -> DictConfig:
    """What rules `rules` change at level `level`: `conf_dir`/rules/level/<rules>_<level>.yaml."""
    path = conf_dir / "rules" / "level" / f"{rules}_{level}.yaml"
    if not path.is_file():
        raise BadInput(f"rules={rules} has no file for level {level!r} ({path}); valid: one per level")
    return OmegaConf.load(path)
