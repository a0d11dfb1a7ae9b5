"""Composing Hydra configs from the CLI and tests, validating them, and laying out run dirs."""

from __future__ import annotations

import copy
import datetime
import importlib.util
import os
import re
import subprocess
from pathlib import Path

from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig, OmegaConf

from mapush.atomic import write_json, write_yaml
from mapush.errors import BadInput, first_line
from mapush.migrations import absent_meant, stamp, upgrade_run_config
from mapush.provenance import provenance
from mapush.records import read_meta
from mapush.resolvers import register_resolvers
from mapush.rules import rules_at_level
from mapush.schema import check_config, task_weight_names
from mapush.untrusted import load_yaml, refuse_links_out

CONF_DIR = Path(os.environ.get("MAPUSH_CONF_DIR", Path(__file__).resolve().parent / "conf"))
"""The `mapush/conf/` tree: package data, so a checkout, an editable install and a wheel all compose alike."""
META_FILE = "meta.json"
"""What made a run (command, seed, git commit), written last: a dir holding it is a run (`rundir.find_runs`)."""


register_resolvers()

GROUPS = ("task", "level", "rules", "lowlevel", "reward", "algo", "critic", "debug")


def group_file(group: str, name: str) -> DictConfig:
    """One config file of a group as written, not composed (e.g. experiment, scale: its sweep axes and budgets)."""
    return OmegaConf.load(CONF_DIR / group / f"{name}.yaml")


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
        for entry in parsed if isinstance(parsed, list) else [parsed]:
            scheme, _, where = str(entry).rpartition("://")
            if scheme == "pkg":
                package, _, sub = where.partition("/")
                try:
                    spec = importlib.util.find_spec(package)
                except ModuleNotFoundError:  # a parent package that is not installed
                    spec = None
                if spec is None or not spec.submodule_search_locations:
                    raise BadInput(f"hydra.searchpath names pkg://{where}, not an installed package; valid: file://DIR")
                dirs.append(Path(next(iter(spec.submodule_search_locations))) / sub)
            else:
                dirs.append(Path(where))
    return dirs


def _check_groups(overrides: list[str]) -> None:
    extra = search_dirs(overrides)
    for override in overrides:
        key, sep, value = override.lstrip("+~").partition("=")
        options = group_options(key, extra) if key in GROUPS else []
        if sep and key in GROUPS and value not in options and not (key == "debug" and value == "null"):
            where = f"in mapush and {', '.join(map(str, extra))}" if extra else "add yours with hydra.searchpath"
            raise BadInput(f"unknown {key} {value!r}; valid: {', '.join(options)} ({where})")


def _unknown_key_message(base: DictConfig, full_key: str) -> str:
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
    overrides = [_run_dir_override(o) for o in overrides] if config_name == "config" else list(overrides)
    _check_groups(overrides)
    key, files = (tuple(overrides), config_name), _files_stamp(search_dirs(overrides))
    if not hydra and _COMPOSED.get(key, (None,))[0] == files:
        return copy.deepcopy(_COMPOSED[key][1])
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        try:
            cfg = compose(config_name=config_name, overrides=overrides, return_hydra_config=hydra)
        except Exception as err:  # Hydra raises several types; all are the user's override mistakes
            full_key = getattr(err.__cause__, "full_key", None)
            if full_key and "not in struct" in str(err.__cause__):
                base = compose(config_name=config_name, overrides=[o for o in overrides if full_key not in o])
                raise BadInput(_unknown_key_message(base, str(full_key))) from None
            raise BadInput(f"bad override: {first_line(err)}") from None
    check_config(cfg, task_weight_names([CONF_DIR, *search_dirs(overrides)]))  # before anything is built or written
    task = [o.split("=", 1)[1] for o in overrides if o.lstrip("+").startswith("task=")][-1:]
    if config_name == "config" and task and cfg.task.name != task[0] and not any("task.name=" in o for o in overrides):
        # a task file copied from another that kept its `name:` would be trained, swept and filed as that one
        raise BadInput(f"task={task[0]}: its file says name: {cfg.task.name}; valid: name: {task[0]} (the file's)")
    if not hydra:
        _COMPOSED[key] = (files, copy.deepcopy(cfg))
        while len(_COMPOSED) > COMPOSED_KEPT:
            _COMPOSED.pop(next(iter(_COMPOSED)))  # the oldest: a long sweep's worker composes job after job
    return cfg


COMPOSED_KEPT = 256
"""How many composed configs a process keeps (a few MB): more than the main table's plan composes."""
_COMPOSED: dict[tuple, tuple[tuple, DictConfig]] = {}
"""Configs this process composed, by overrides and config name, with the config files' stamp they were composed
from: a sweep plans each stage more than once, and Hydra reads every file anew each time (about 0.4 s)."""


def _files_stamp(extra_dirs: list[Path]) -> tuple:
    """Every config file's path, size and modification time: a composed config stands while this is the same."""
    paths = sorted(p for d in (CONF_DIR, *extra_dirs) for p in Path(d).rglob("*.yaml"))
    stats = [p.stat() for p in paths]
    return tuple((str(p), s.st_size, s.st_mtime_ns) for p, s in zip(paths, stats, strict=True))


def _run_dir_override(override: str) -> str:
    """Hydra's `hydra.run.dir=DIR` (a Hydra app's run dir) is mapush's `train.run_dir=DIR`."""
    key, sep, value = override.partition("=")
    return f"train.run_dir={value}" if sep and key.lstrip("+") == "hydra.run.dir" else override


def sim_threads(cfg: DictConfig | dict) -> int:
    """The MuJoCo threads a config steps its batch with: `sim.nthread`, where 0 means every core of this machine."""
    return int(cfg["sim"]["nthread"]) or os.cpu_count() or 1


def overrides_name(overrides: list[str]) -> str:
    """A file-name tag for an evaluation's overrides (`task.num_agents=3` -> `task.num_agents-3`); '' for none."""
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", "_".join(overrides)).strip("-")


def env_steps_per_iteration(cfg: dict) -> int:
    """50 Hz control steps of one env that one PPO iteration trains on (a high-level decision holds several)."""
    per_decision = int(cfg["level"].get("decision_steps", 1))
    return int(cfg["num_envs"]) * int(cfg["algo"]["num_steps_per_env"]) * per_decision


def to_plain(cfg: DictConfig) -> dict:
    """The config as plain, resolved Python containers (what rsl-rl and the env receive)."""
    return OmegaConf.to_container(cfg, resolve=True)


def git_state() -> dict:
    """The commit of the mapush checkout and whether it has uncommitted changes (None outside git)."""
    root = CONF_DIR.parent  # inside the checkout (git finds the repository from any dir in it)
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True)
        status = subprocess.run(["git", "status", "--porcelain"], cwd=root, capture_output=True, text=True)
        return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}
    except (OSError, subprocess.CalledProcessError):
        return {"commit": None, "dirty": None}


def new_run_dir(cfg: DictConfig) -> Path:
    """A fresh `runs/<level>/<subject>/<time>__seed<seed>` dir (suffixed if that name is taken), or `train.run_dir`
    when set (it must be new or empty). The subject is the task, or what the level names instead (`level.subject`:
    the low level's robot)."""
    chosen = cfg.train.get("run_dir")
    if chosen:
        run_dir = Path(chosen)
        if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
            raise BadInput(f"train.run_dir={chosen!r} exists and is not empty; valid: a new or empty dir")
        run_dir.mkdir(parents=True, exist_ok=True)
        return run_dir
    stamp = datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    subject = cfg.level.get("subject") or cfg.task.name
    base = Path(cfg.train.run_root) / cfg.level.name / subject / f"{stamp}__seed{cfg.seed}"
    run_dir, k = base, 1
    while run_dir.exists():
        run_dir, k = base.with_name(f"{base.name}_{k}"), k + 1
    run_dir.mkdir(parents=True)
    return run_dir


def save_run_config(run_dir: Path, cfg: DictConfig, overrides: list[str], command: str) -> None:
    """Write what made the run: `config.yaml` (composed), `overrides.yaml`, `meta.json` (git, `provenance`, seed,
    command), and `.hydra/` as every Hydra app's run dir has it (`config.yaml`, `overrides.yaml`, `hydra.yaml`)."""
    meta = {"command": command, "seed": int(cfg.seed), **git_state(), **provenance()}  # a wheel has no commit
    meta["created"] = datetime.datetime.now().isoformat()
    hydra_dir = run_dir / ".hydra"
    hydra_dir.mkdir(exist_ok=True)
    hydra_node = compose_config(overrides, hydra=True).hydra
    hydra_node.run.dir = str(run_dir)
    for directory in (hydra_dir, run_dir):  # config.yaml last: it is what makes a dir a run
        write_yaml(directory / "overrides.yaml", list(overrides))
        write_yaml(directory / "config.yaml", cfg, resolve=True)
    write_yaml(hydra_dir / "hydra.yaml", {"hydra": hydra_node})
    write_json(run_dir / META_FILE, stamp(meta))


def lengthen_run(run_dir: Path, iterations: int, command: str, meta_from: Path | None = None) -> None:
    """Record that run `run_dir` trains on to `iterations`: `train.iterations` in its `config.yaml` (and `.hydra/`'s),
    the override at the end of its `overrides.yaml`, and the step in `meta.json`'s `lengthened` (the iterations it
    had, the commit, the command, when), so that the run says what it learned and a cut one resumes to its end.

    `meta_from`: the `meta.json` to extend (a copied run's source); `meta.json`, what makes a dir a run, is written
    last."""
    run_dir = Path(run_dir)
    meta = read_meta(Path(meta_from or run_dir / META_FILE))  # a cut or altered one refused before any write
    before = int(load_yaml(run_dir / "config.yaml").train.iterations)
    for directory in (run_dir / ".hydra", run_dir):
        if not (directory / "config.yaml").is_file():
            continue
        cfg = load_yaml(directory / "config.yaml")
        cfg.train.iterations = int(iterations)
        overrides = list(load_yaml(directory / "overrides.yaml"))
        write_yaml(directory / "overrides.yaml", [*overrides, f"train.iterations={int(iterations)}"])
        write_yaml(directory / "config.yaml", cfg)
    step = {"from_iterations": before, "to_iterations": int(iterations), "command": command}
    step |= git_state() | provenance()
    meta["lengthened"] = [*meta.get("lengthened", []), {**step, "at": datetime.datetime.now().isoformat()}]
    write_json(run_dir / META_FILE, meta)


def load_run_config(run_dir: Path) -> DictConfig:
    """The composed config a run was made with; BadInput if `run_dir` is not a run.

    Root settings, and settings of the run's level at any depth, added to mapush after the run was made (e.g.
    `log`) take their current defaults, or the value runs ran with before they existed (`migrations.ABSENT_MEANT`);
    everything the run saved stays as it was.
    """
    path = Path(run_dir) / "config.yaml"
    if not Path(run_dir).is_dir() or not path.is_file():
        raise BadInput(f"{str(run_dir)!r} is not a run dir (no config.yaml); valid: a dir that `mapush train` made")
    refuse_links_out(Path(run_dir))  # its config, checkpoints and logs are its own, not a link's target
    root = OmegaConf.load(CONF_DIR / "config.yaml")
    root.pop("defaults")
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
    run = upgrade_run_config(run)
    name = OmegaConf.select(run, "level.name", default="")
    if (CONF_DIR / "level" / f"{name}.yaml").is_file():
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


def _term_tables(run: DictConfig) -> list[str]:
    """The run's tables of named terms ({func, params}): its exceptions and each observation group."""
    groups = OmegaConf.select(run, "level.observations", default=None) or {}
    tables = ["level.exceptions"] if OmegaConf.select(run, "level.exceptions", default=None) else []
    return tables + [f"level.observations.{group}" for group, terms in groups.items() if terms]


def level_defaults(name: str) -> DictConfig:
    """The settings `level=<name>` composes to today: the level and map files it builds on, then its own (read
    without Hydra, which may be running the caller). Its reward and algo overrides are not followed."""
    node = OmegaConf.load(CONF_DIR / "level" / f"{name}.yaml")
    merged = OmegaConf.create()
    for entry in node.pop("defaults", []):
        if not isinstance(entry, str) or entry == "_self_":
            continue  # `override /reward...` entries are dicts
        if entry.startswith("/"):  # a group file placed here, e.g. /map/long_horizon@_here_
            merged = OmegaConf.merge(merged, OmegaConf.load(CONF_DIR / f"{entry.split('@')[0].lstrip('/')}.yaml"))
        else:  # another level file
            merged = OmegaConf.merge(merged, level_defaults(entry))
    return OmegaConf.merge(merged, node)


SWAPPABLE_GROUPS = ("task", "level", "rules", "lowlevel", "reward")
"""Groups whose file can replace a saved run's node in `apply_overrides`."""


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
        key, value = override.key_or_group, override.value()
        exists = OmegaConf.select(cfg, key, default="<missing>") != "<missing>"
        if key in GROUPS:
            if key not in SWAPPABLE_GROUPS:
                raise BadInput(f"group {key!r} cannot change for an existing run; valid: {', '.join(SWAPPABLE_GROUPS)}")
            _check_groups([f"{key}={value}"])
            if key == "rules":  # the rules at the run's level, merged into its level node
                cfg.level = OmegaConf.merge(cfg.level, rules_at_level(CONF_DIR, str(value), str(cfg.level.name)))
            else:
                cfg[key] = OmegaConf.load(CONF_DIR / key / f"{value}.yaml")
        elif override.is_delete():
            if not exists:
                raise BadInput(_unknown_key_message(cfg, key))
            parent, _, leaf = key.rpartition(".")
            node = OmegaConf.select(cfg, parent) if parent else cfg
            node.pop(leaf)
        elif override.is_add() and exists:
            raise BadInput(f"config key {key!r} already exists; valid: {key}=VALUE")
        elif not exists and not (override.is_add() or override.is_force_add()):
            raise BadInput(_unknown_key_message(cfg, key))
        else:
            OmegaConf.update(cfg, key, value, merge=False, force_add=True)
    check_config(cfg)
    return cfg
