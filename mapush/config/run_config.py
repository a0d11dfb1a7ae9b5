"""A saved run's config read back: what it was made with, with settings added to mapush since then taking their
current defaults (or what runs ran with before they existed), and a level's settings as composed today."""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from mapush.config import groups
from mapush.errors import BadInput, first_line
from mapush.migrations import absent_meant, upgrade_run_config
from mapush.untrusted import load_yaml, refuse_links_out


def load_run_config(run_dir: Path) -> DictConfig:
    """The composed config a run was made with; BadInput if `run_dir` is not a run.

    Root settings, and settings of the run's level at any depth, added to mapush after the run was made (e.g.
    `log`) take their current defaults, or the value runs ran with before they existed (`migrations.ABSENT_MEANT`);
    everything the run saved stays as it was.
    """
    run = upgrade_run_config(_read_run_config(Path(run_dir)))
    root = OmegaConf.load(groups.CONF_DIR / "config.yaml")
    root.pop("defaults")
    name = OmegaConf.select(run, "level.name", default="")
    if (groups.CONF_DIR / "level" / f"{name}.yaml").is_file():
        root.level = level_defaults(name)
    cfg = OmegaConf.merge(root, run)
    for table in _term_tables(run):  # a term the run saved is the run's, not merged with today's of its name
        for term, spec in OmegaConf.select(run, table).items():
            OmegaConf.update(cfg, f"{table}.{term}", spec, merge=False)
    absent_meant(run, cfg)
    mid = cfg.get("mid")
    if mid and not Path(mid).is_absolute() and (Path(run_dir) / mid).exists():  # a shipped hierarchy's own mid level
        cfg.mid = str((Path(run_dir) / mid).resolve())
    return cfg


def _read_run_config(run_dir: Path) -> DictConfig:
    """`run_dir/config.yaml` as saved; BadInput if the dir is not a run, links out, or its config is not one."""
    path = run_dir / "config.yaml"
    if not run_dir.is_dir() or not path.is_file():
        raise BadInput(f"{str(run_dir)!r} is not a run dir (no config.yaml); valid: a dir that `mapush train` made")
    refuse_links_out(run_dir)  # its config, checkpoints and logs are its own, not a link's target
    try:
        run = load_yaml(path)
    except BadInput:
        raise
    except Exception as err:  # YAML's and OmegaConf's parse errors have many types
        first = first_line(err)
        raise BadInput(
            f"{str(path)!r} is not a readable config ({first}); valid: the config.yaml a run was made with"
        ) from None
    if not isinstance(run, DictConfig) or "level" not in run or "task" not in run:
        raise BadInput(
            f"{str(path)!r} is not a run's config (empty, or no level or task); valid: the config.yaml "
            "a run was made with"
        )
    return run


def _term_tables(run: DictConfig) -> list[str]:
    """The run's tables of named terms ({func, params}): its exceptions and each observation group."""
    observations = OmegaConf.select(run, "level.observations", default=None) or {}
    tables = ["level.exceptions"] if OmegaConf.select(run, "level.exceptions", default=None) else []
    return tables + [f"level.observations.{group}" for group, terms in observations.items() if terms]


def level_defaults(name: str) -> DictConfig:
    """The settings `level=<name>` composes to today: the level and map files it builds on, then its own (read
    without Hydra, which may be running the caller). Its reward and algo overrides are not followed."""
    node = OmegaConf.load(groups.CONF_DIR / "level" / f"{name}.yaml")
    merged = OmegaConf.create()
    for entry in node.pop("defaults", []):
        if not isinstance(entry, str) or entry == "_self_":
            continue  # `override /reward...` entries are dicts
        if entry.startswith("/"):  # a group file placed here, e.g. /map/long_horizon@_here_
            merged = OmegaConf.merge(
                merged, OmegaConf.load(groups.CONF_DIR / f"{entry.split('@')[0].lstrip('/')}.yaml")
            )
        else:  # another level file
            merged = OmegaConf.merge(merged, level_defaults(entry))
    return OmegaConf.merge(merged, node)
