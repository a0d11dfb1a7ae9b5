"""A new run dir, and the files in it that say what made the run: its composed config, its overrides, and
`meta.json` (git, provenance, seed, command; lengthened runs' steps)."""

from __future__ import annotations

import datetime
from pathlib import Path

from omegaconf import DictConfig

from mapush.atomic import write_json, write_yaml
from mapush.config.compose import compose_config
from mapush.config.git import git_state
from mapush.errors import BadInput
from mapush.migrations import stamp
from mapush.provenance import provenance
from mapush.records import read_meta
from mapush.untrusted import load_yaml

META_FILE = "meta.json"
"""What made a run (command, seed, git commit), written last: a dir holding it is a run (`rundir.find_runs`)."""


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
    started = datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    subject = cfg.level.get("subject") or cfg.task.name
    base = Path(cfg.train.run_root) / cfg.level.name / subject / f"{started}__seed{cfg.seed}"
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
