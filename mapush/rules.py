"""The rule sets (`conf/rules/`): what ends an episode at each level, the original's (`rules=original`) or mapush's
(`rules=strict`, the default). A rule set is one file per level, `conf/rules/level/<rules>_<level>.yaml`, merged into
the level node; docs/fidelity.md, "Rules: what ends an episode", gives each rule's source."""

from __future__ import annotations

from pathlib import Path

from omegaconf import OmegaConf

ORIGINAL_COLLISION_M = {"tblock": 0.27}
"""m; the original's base-distance collision threshold per task where it was not 0.25 (its task configs)."""


def original_collision_m(task: str) -> float:
    """The distance (m) between two robot bases at which the original ended a push on task `task`: 0.25 m, 0.27 m
    on the T-block (its task configs' `termination.collision_kwargs`); the resolver `${original_collision_m:...}`."""
    return ORIGINAL_COLLISION_M.get(str(task), 0.25)


def rule_keys(conf_dir: Path, level: str) -> list[str]:
    """The keys of the level node that some rule set sets at level `level` (other than `rules`, its name): what
    swapping the rules of a saved run has to take from the new set (`config.overrides`)."""
    keys: set[str] = set()
    for path in sorted((conf_dir / "rules" / "level").glob(f"*_{level}.yaml")):
        if path.stem.split("_", 1)[1] == level:  # strict_mid.yaml, not strict_mid_long.yaml
            keys |= set(OmegaConf.load(path)) - {"rules"}
    return sorted(keys)
