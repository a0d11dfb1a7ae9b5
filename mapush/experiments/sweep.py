"""`mapush sweep`, `ablate` and `scale`: Hydra multiruns of sweep jobs (`pipeline.run_job`) through a launcher.

The sweep's axes come from the experiment file (`sweep:` lists and the budget's seeds) unless given on the
command line as comma lists. Every job gets a fixed dir named by its overrides under
`<sweep_root>/<experiment>_<budget>/`, so running the same command again skips the finished jobs and resumes the
cut ones. A job that fails writes `failed.txt` and lets the others run; the failures are listed at the end.
"""

from __future__ import annotations

import os
import sys
import traceback
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import Glob
from omegaconf import DictConfig, OmegaConf

from mapush.config import (
    CONF_DIR,
    compose_config,
    group_file,
    group_options,
    load_run_config,
    overrides_name,
    search_dirs,
    to_plain,
)
from mapush.errors import BadInput, first_line
from mapush.experiments import stages
from mapush.experiments.archive import archived_result, job_made_already, load_results, result_roots
from mapush.experiments.results import RESULT, every_stage_override, read_result
from mapush.experiments.stage_plan import budget_of, planned_stages, stages_with_overrides
from mapush.experiments.staleness import result_changes
from mapush.experiments.workers import SWEEP_PID, job_threads, stop_with_the_sweep

SWEEP_YAML = OmegaConf.to_container(OmegaConf.load(CONF_DIR / "sweep.yaml"))  # as written: interpolations kept
DEFAULTS = {key: value for entry in SWEEP_YAML["defaults"] if entry != "_self_" for key, value in entry.items()}
DEFAULTS |= {key: value for key, value in SWEEP_YAML.items() if key not in ("defaults", "hydra")}
"""Every key of a sweep job (conf/sweep.yaml), the groups first, with its default (method: ours, budget: quick...)."""
SWEEP_GROUPS = tuple(key for entry in SWEEP_YAML["defaults"] if entry != "_self_" for key in entry)
STAGE_GROUPS = ("task",)
"""Sweep groups that each stage composes again from the job's choice (`task=<name>`): a field of one
(`task.object.friction=...`) goes to the stages, not to the sweep, or the stages would never see it."""
NAMED_GROUPS = ("method", "experiment")
"""Groups whose files repeat their name (`name:`), which files their jobs and cells: a copy must change it."""
SWEEP_KEYS = tuple(DEFAULTS)
"""Keys of conf/sweep.yaml; any other override (e.g. `debug=smoke`, `algo.entropy_coef=0.01`) goes to every stage."""
FAILED = "failed.txt"
OPTIONAL_LAUNCHERS = {"ray": ("hydra_plugins.hydra_ray_launcher", "hydra-ray-launcher: pip install -e .[ray]")}
"""Launchers whose plugin is an optional install: the module to import, and what to install."""

if not OmegaConf.has_resolver("cores"):
    OmegaConf.register_new_resolver("cores", lambda: os.cpu_count() or 1)


@hydra.main(config_path=str(CONF_DIR), config_name="sweep", version_base="1.3")
def job(cfg: DictConfig) -> str:
    """One sweep job in its Hydra output dir. A failure is written to `failed.txt` and the other jobs run on; only an
    interrupt, or the sweep's own end, stops the worker."""
    from mapush.experiments.pipeline import run_job  # training's machinery (PyTorch): loaded where jobs run

    job_dir = Path(HydraConfig.get().runtime.output_dir)
    (job_dir / FAILED).unlink(missing_ok=True)
    between_jobs = stop_with_the_sweep()
    between_jobs.clear()
    try:
        run_job(cfg, job_dir, job_threads(cfg))
        return "ok"
    except BaseException as err:  # the job reports and returns; an interrupt, or its sweep gone, ends the process
        (job_dir / FAILED).write_text("".join(traceback.format_exception(err)))
        if isinstance(err, KeyboardInterrupt) or (isinstance(err, SystemExit) and between_jobs.sweep_gone):
            raise
        return f"failed: {err}"
    finally:
        between_jobs.set()


def sweep_overrides(overrides: list[str]) -> list[str]:
    """The command line overrides plus the experiment's axes that the user did not give (as comma lists).

    Overrides that are not sweep keys are passed to every stage (`overrides=[...]`). Checked before anything
    launches: group names (method, experiment, launcher), the budget, and that each job's stages compose (tasks,
    agent counts, stage overrides).
    """
    listed = [o for o in overrides if o.startswith("overrides=")]  # stage overrides as a list: as if given bare
    overrides = [_as_axis(o) for o in [*(o for o in overrides if o not in listed), *_list_items(listed)]]
    stage = [o for o in overrides if not _is_sweep_key(o)]
    overrides = [o for o in overrides if _is_sweep_key(o)]
    searchpath = [o for o in overrides if _is_searchpath(o)]  # the sweep's and every stage's: tasks of yours
    if stage or searchpath:
        overrides.append(every_stage_override(stage + searchpath))
        if stage and not any(o.startswith("sweep_name=") for o in overrides):  # keep them apart from the plain sweep
            overrides.append(f"sweep_name=${{experiment.name}}_${{budget}}_{overrides_name(stage)}")
    given = {o.partition("=")[0]: o.partition("=")[2] for o in overrides if "=" in o}
    given_axes = _split_axes(overrides)
    for group in SWEEP_GROUPS:  # tasks may be yours (`hydra.searchpath`); methods and experiments are mapush's
        options = group_options(group, search_dirs(overrides) if group in STAGE_GROUPS else ())
        for value in given_axes.get(group, []):
            if value not in options:
                raise BadInput(f"unknown {group} {value!r}; valid: {', '.join(options)}")
            if group in NAMED_GROUPS and group_file(group, value).name != value:  # a copy that kept its name
                raise BadInput(
                    f"{group}={value}: its file says name: {group_file(group, value).name}; valid: name: {value}"
                )
    launcher = given.get("launcher", DEFAULTS["launcher"])
    _check_launcher_plugin(launcher)
    experiment = group_file("experiment", given.get("experiment", DEFAULTS["experiment"]))
    budget_name = given.get("budget", DEFAULTS["budget"])
    budget = budget_of(OmegaConf.create({"experiment": experiment, "budget": budget_name}))
    axes = {**{k: list(v) for k, v in experiment.sweep.items()}, "seed": list(budget.seeds)}
    full = list(overrides)
    for key, values in axes.items():
        if key not in given:
            full.append(f"{key}={','.join(str(v) for v in values)}")
    _check_jobs(full)
    return full


AXIS_ALIASES = {"task.num_agents": "agents"}
"""Stage keys that a sweep takes as its own axis (`task.num_agents=1,2,3` sweeps `agents`)."""


def _as_axis(override: str) -> str:
    key, sep, value = override.partition("=")
    return f"{AXIS_ALIASES[key]}={value}" if sep and key in AXIS_ALIASES else override


def _list_items(listed: list[str]) -> list[str]:
    """The items of `overrides=[...]` overrides, each one override."""
    items = []
    for text in listed:
        try:
            items += [str(item) for item in OverridesParser.create().parse_override(text).value()]
        except Exception as err:  # Hydra's grammar errors: the user's typing
            raise BadInput(f"bad override {text!r} ({first_line(err)}); valid: overrides=['key=value',...]") from None
    return items


def _is_searchpath(override: str) -> bool:
    return override.partition("=")[0] == "hydra.searchpath"


def _is_sweep_key(override: str) -> bool:
    key = override.lstrip("+~").partition("=")[0]
    head = key.split(".")[0]
    if head in STAGE_GROUPS and key != head:
        return False
    return head in SWEEP_KEYS or head == "hydra"


def _split_axes(overrides: list[str]) -> dict[str, list[str]]:
    """Each override's values, by Hydra's own sweep grammar: `seed=0,1`, `agents=range(1,5)`,
    `task=choice(cuboid,tblock)`, `task=glob(c*)` (a group's files); a list (`overrides=[...]`) is one value."""
    parser = OverridesParser.create()
    axes = {}
    for text in overrides:
        try:
            override = parser.parse_override(text)
        except Exception as err:  # Hydra's grammar errors: the user's typing
            raise BadInput(f"bad override {text!r} ({first_line(err)}); valid: key=value") from None
        key, value = override.get_key_element(), override.value()
        if isinstance(value, Glob):
            if override.key_or_group not in SWEEP_GROUPS:
                raise BadInput(f"glob() in {text!r} picks files of a group; valid: {', '.join(SWEEP_GROUPS)}")
            extra = search_dirs([o for o in overrides if _is_searchpath(o)]) if key in STAGE_GROUPS else ()
            axes[key] = value.filter(group_options(override.key_or_group, extra))
        elif override.is_sweep_override():
            axes[key] = list(override.sweep_string_iterator())
        else:
            axes[key] = [override.get_value_element_as_str()]
    return axes


def _check_launcher_plugin(launcher: str) -> None:
    if launcher not in OPTIONAL_LAUNCHERS:
        return
    module, install = OPTIONAL_LAUNCHERS[launcher]
    try:
        __import__(module)
    except ImportError:
        raise BadInput(f"launcher={launcher} is not installed; valid: install {install}") from None


def job_combos(overrides: list[str], seeds: bool = True) -> list[list[str]]:
    """Every job of a sweep as its list of `key=value` axis overrides (`seeds=False`: the first seed's jobs only)."""
    combos: list[list[str]] = [[o for o in overrides if _is_searchpath(o)]]  # every job composes its tasks there
    for key, values in _split_axes(overrides).items():
        if key == "launcher" or key.startswith("hydra"):
            continue
        combos = [[*c, f"{key}={v}"] for c in combos for v in (values if seeds or key != "seed" else values[:1])]
    return combos


def _check_jobs(overrides: list[str]) -> None:
    """Compose every job's stages (without training) so that a bad method, task or agent count fails now."""
    from mapush.levels import env_class  # the envs (PyTorch): loaded once the sweep's names are known good

    checked: set[tuple[str, ...]] = set()
    # the seed changes no stage's validity; the first seed's configs, composed here, are those a dry run plans next
    for combo in job_combos(overrides, seeds=False):
        for _, stage_overrides in stages_with_overrides(compose_config(combo, config_name="sweep")):
            key = tuple(o for o in stage_overrides if not stages.is_ref(o))
            if key not in checked:
                checked.add(key)
                plain = to_plain(compose_config(list(key)))
                env_class(plain).validate(plain)


def dry_run(overrides: list[str]) -> list[dict]:
    """What `run_sweep(overrides)` would train and reuse, job by job, training nothing; printed and returned.

    Finished jobs are left out (those whose experiment changed since are listed; see `rerun_changed`), and so are
    jobs another sweep's job made already (`archive.job_made_already`), whose results the sweep takes. Each row of
    the others: job, stage, identity, `action` (`train`, `resume` from `done` of its `iterations`, `reuse` a finished
    stage, `share` a stage an earlier job of this sweep trains, or `train_on` from `done` iterations of a finished
    stage that is this one with a shorter budget, `stages.shorter_twin`) and the stage's env-steps.
    """
    full = sweep_overrides(overrides)
    combos = job_combos(full)
    hydra_cfg = compose_config(combos[0], config_name="sweep", hydra=True).hydra
    unnamed = set(hydra_cfg.job.config.override_dirname.exclude_keys)  # keys the job dirs' names leave out
    rows, seen, changed, finished, taken = [], set(), [], 0, 0
    roots = result_roots(compose_config(combos[0], config_name="sweep"))
    finished_results = load_results(roots)
    rates = stages.cost_per_env_step(finished_results, roots)
    for combo in combos:
        cfg = compose_config(combo, config_name="sweep")
        named = (o for o in combo if o.partition("=")[0] not in unnamed and not _is_searchpath(o))
        job = ",".join(sorted(named))  # Hydra's override_dirname
        planned = planned_stages(cfg)
        result = Path(hydra_cfg.sweep.dir) / job / RESULT
        if not result.is_file() and archived_result(cfg, result.parent, planned) is not None:
            finished += 1  # finished on another machine, and archived (`mapush archive`)
            continue
        if not result.is_file() and job_made_already(cfg, result.parent, planned, finished_results) is not None:
            finished, taken = finished + 1, taken + 1  # made already by another sweep's job
            continue
        if result.is_file():
            why = result_changes(read_result(result), cfg, planned)
            finished += 1
            if not why:
                continue  # finished as planned now: nothing to train or evaluate
            changed.append(f"{job}: {why}")
            if not cfg.rerun_changed:
                continue
        identities = {stage.name: stage.identity for stage in planned}
        for stage in planned:
            done = stages.trained_iterations(stages.stage_dir(Path(cfg.sweep_root), stage.identity))
            action = "share" if stage.identity in seen else "reuse" if done is None else "resume" if done else "train"
            twin = None if action != "train" else \
                stages.shorter_twin(Path(cfg.sweep_root), stage.cfg, stage.overrides, identities)  # fmt: skip
            if twin is not None:
                action, done = "train_on", int(load_run_config(twin).train.iterations)
            left = 0.0 if action in ("share", "reuse") else stage.env_steps * (1 - done / stage.iterations)
            rate = rates.get(stage.shape)
            seen.add(stage.identity)
            rows.append({"job": job, "stage": stage.name, "identity": stage.identity, "action": action, "done": done,
                         "iterations": stage.iterations, "env_steps": stage.env_steps,
                         "core_s": None if rate is None else rate * left})  # fmt: skip
    to_train = [r for r in rows if r["action"] in TRAINS]
    made = f" ({taken} made already by other sweeps' jobs, their results to be taken)" if taken else ""
    print(f"sweep {hydra_cfg.sweep.dir}: {len(combos)} jobs, {finished} finished{made}; {len(rows)} stages to run; "
          f"{len(to_train)} to train ({sum(r['env_steps'] for r in to_train) / 1e6:.1f}M env-steps), "
          f"{sum(r['action'] == 'reuse' for r in rows)} finished to reuse, "
          f"{sum(r['action'] == 'share' for r in rows)} shared between jobs")  # fmt: skip
    if to_train:
        print(_estimate_line(to_train))
    if changed:
        print(
            f"{len(changed)} finished jobs were made by other stages or evaluations than planned now; "
            + ("they run again:" if cfg.rerun_changed else "kept as they are (rerun_changed=true runs them again):")
        )
        for line in changed:
            print(f"  {line}")
    width = max((len(r["job"]) for r in rows), default=0)
    for r in rows:
        hours = "" if r["action"] in ("reuse", "share") else "  no measured stage like it" if r["core_s"] is None \
            else f"  ~{r['core_s'] / 3600:.2f} core-h"  # fmt: skip
        print(f"  {r['job']:{width}s}  {r['stage']:5s} {r['identity']}  {_action_text(r):18s} "
              f"{r['env_steps'] / 1e6:8.2f}M env-steps{hours}")  # fmt: skip
    return rows


TRAINS = ("train", "resume", "train_on")
"""A dry run's actions that train: from scratch, from the stage's last checkpoint, on from a shorter twin."""


def _action_text(row: dict) -> str:
    done = f" {row['done']}/{row['iterations']}" if row["action"] in ("resume", "train_on") else ""
    return {"resume": "resume from", "train_on": "train on"}.get(row["action"], row["action"]) + done


def _estimate_line(to_train: list[dict]) -> str:
    """The training time the dry run expects: measured core-seconds per env-step of finished stages of the same
    `stages.shape`, times the env-steps each stage has left."""
    known = [r["core_s"] for r in to_train if r["core_s"] is not None]
    like = "of the same level, object, robots, envs and low level"
    if not known:
        return f"  training time: not estimated (no finished stage {like} has a measured time)"
    unknown = len(to_train) - len(known)
    return (
        f"  training time, estimated from finished stages {like}: {sum(known) / 3600:.1f} core-hours for "
        f"{len(known)} of the {len(to_train)} stages to train"
        + (f" ({unknown} not estimated: no measured stage like them)" if unknown else "")
    )


def run_sweep(overrides: list[str]) -> tuple[Path, list[Path], list[Path]]:
    """Launch the multirun; returns the sweep dir, the finished job dirs and the failed job dirs."""
    full = sweep_overrides(overrides)
    os.environ[SWEEP_PID] = str(os.getpid())  # the workers it starts exit with it
    argv = sys.argv
    sys.argv = [argv[0], "--multirun", *full]
    try:
        job()
    except SystemExit as err:  # hydra exits on its own errors
        if err.code:
            raise BadInput(f"the sweep did not launch (hydra exit {err.code}); see the message above") from None
    finally:
        sys.argv = argv
    sweep_dir = _sweep_dir(full)
    finished = sorted(p.parent for p in sweep_dir.glob(f"*/{RESULT}"))
    failed = sorted(p.parent for p in sweep_dir.glob(f"*/{FAILED}"))
    return sweep_dir, finished, failed


def _sweep_dir(overrides: list[str]) -> Path:
    """The multirun's dir: the same for every job, so the first value of each axis will do."""
    first = [f"{key}={values[0]}" for key, values in _split_axes(overrides).items()]
    return Path(compose_config(first, config_name="sweep", hydra=True).hydra.sweep.dir)


def report(sweep_dir: Path, finished: list[Path], failed: list[Path]) -> int:
    """Print the sweep's outcome; returns the exit code (1 when a job failed)."""
    print(f"sweep {sweep_dir}: {len(finished)} jobs finished, {len(failed)} failed")
    for path in finished:
        result = read_result(path / RESULT)
        cells = ", ".join(
            f"{name} S.R. {100 * e['success_rate']:.1f}% C.T. {e['completion_time']:.3f}"
            for name, e in result.evals.items()
        )
        print(f"  {path.name}: {cells}")
    for path in failed:
        last = (path / FAILED).read_text().strip().splitlines()[-1]
        print(f"  FAILED {path.name}: {last} (traceback in {path / FAILED})")
    return 1 if failed else 0
