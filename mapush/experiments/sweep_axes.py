"""What a sweep's command line means: its axes, its jobs, and every job's planned stages (`planned_jobs`).

`sweep_overrides` checks the command line and completes it from the experiment file (`sweep:` lists, the budget's
seeds); `job_combos` splits it into jobs by Hydra's sweep grammar; `planned_jobs` composes each job and plans its
stages. `sweep.py` launches them, or (`--dry-run`) prints what they would train.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass

from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import Glob
from omegaconf import DictConfig, OmegaConf

from mapush.config import CONF_DIR, compose_config, group_file, group_options, overrides_name, search_dirs, to_plain
from mapush.errors import BadInput, first_line
from mapush.experiments import plan_memo, stages
from mapush.experiments.job_records import CurveRule
from mapush.experiments.results import every_stage_override
from mapush.experiments.stage_plan import PlannedStage, budget_of, planned_stages, stages_with_overrides

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
OPTIONAL_LAUNCHERS = {"ray": ("hydra_plugins.hydra_ray_launcher", "hydra-ray-launcher: pip install -e .[ray]")}
"""Launchers whose plugin is an optional install: the module to import, and what to install."""

if not OmegaConf.has_resolver("cores"):
    OmegaConf.register_new_resolver("cores", lambda: os.cpu_count() or 1)


def sweep_overrides(overrides: list[str]) -> list[str]:
    """The command line overrides plus the experiment's axes that the user did not give (as comma lists).

    Overrides that are not sweep keys are passed to every stage (`overrides=[...]`); `debug=smoke` without a
    budget means `budget=smoke` too, as only the budget sets a stage's iterations. Checked before anything
    launches: group names (method, experiment, launcher), the budget, and that each job's stages compose (tasks,
    agent counts, stage overrides).
    """
    listed = [o for o in overrides if o.startswith("overrides=")]  # stage overrides as a list: as if given bare
    overrides = [_as_axis(o) for o in [*(o for o in overrides if o not in listed), *_list_items(listed)]]
    if "debug=smoke" in overrides and not any(o.startswith("budget=") for o in overrides):
        overrides.append("budget=smoke")  # a smoke sweep is short: its stages' iterations come from the budget
    stage = [o for o in overrides if not _is_sweep_key(o)]
    overrides = [o for o in overrides if _is_sweep_key(o)]
    searchpath = [o for o in overrides if is_searchpath(o)]  # the sweep's and every stage's: tasks of yours
    if stage or searchpath:
        overrides.append(every_stage_override(stage + searchpath))
        if stage and not any(o.startswith("sweep_name=") for o in overrides):  # keep them apart from the plain sweep
            overrides.append(f"sweep_name=${{experiment.name}}_${{budget}}_{overrides_name(stage)}")
    given = {o.partition("=")[0]: o.partition("=")[2] for o in overrides if "=" in o}
    given_axes = split_axes(overrides)
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
    if not plan_memo.known(full):  # a remembered plan was composed and checked as it stands now
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


def is_searchpath(override: str) -> bool:
    return override.partition("=")[0] == "hydra.searchpath"


def _is_sweep_key(override: str) -> bool:
    key = override.lstrip("+~").partition("=")[0]
    head = key.split(".")[0]
    if head in STAGE_GROUPS and key != head:
        return False
    return head in SWEEP_KEYS or head == "hydra"


def split_axes(overrides: list[str]) -> dict[str, list[str]]:
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
            extra = search_dirs([o for o in overrides if is_searchpath(o)]) if key in STAGE_GROUPS else ()
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
    combos: list[list[str]] = [[o for o in overrides if is_searchpath(o)]]  # every job composes its tasks there
    for key, values in split_axes(overrides).items():
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
        job = compose_config(combo, config_name="sweep")
        _check_curve_keys(job)
        for _, stage_overrides in stages_with_overrides(job):
            key = tuple(o for o in stage_overrides if not stages.is_ref(o))
            if key not in checked:
                checked.add(key)
                plain = to_plain(compose_config(list(key)))
                env_class(plain).validate(plain)


CURVE_SPEC_KEYS = ("eval", "every_env_steps", "reach", "stages")
"""What a budget's `curve:` may say; the rest of a result's curve (`job_records.Curve`) is drawn."""
RULE_KEYS = tuple(f.name for f in dataclasses.fields(CurveRule))
"""What an experiment's `budget_rule:` says (`job_records.CurveRule`)."""


def _check_curve_keys(job: DictConfig) -> None:
    """A budget's learning curve and the experiment's budget rule name only keys a result's curve holds: a job's
    record is written after all its training, too late to find a typo there."""
    curve = budget_of(job).get("curve") or {}
    unknown = sorted(set(curve) - set(CURVE_SPEC_KEYS))
    if unknown:
        raise BadInput(f"budget {job.budget}'s curve has unknown keys {unknown}; valid: {', '.join(CURVE_SPEC_KEYS)}")
    rule = set(job.experiment.get("budget_rule") or {})
    if rule and rule != set(RULE_KEYS):
        raise BadInput(
            f"experiment {job.experiment.name}'s budget_rule has {sorted(rule)}; valid: {', '.join(RULE_KEYS)}"
        )


@dataclass(frozen=True)
class PlannedJob:
    """One job of a sweep: its axis overrides (`combo`), its composed config and the stages it trains, in order."""

    combo: list[str]
    cfg: DictConfig
    stages: list[PlannedStage]

    def name(self, unnamed: set[str]) -> str:
        """Its dir's name as Hydra writes it (`override_dirname`): its axes, sorted, less the keys `unnamed`."""
        return ",".join(sorted(o for o in self.combo if o.partition("=")[0] not in unnamed and not is_searchpath(o)))


def planned_jobs(full: list[str]) -> list[PlannedJob]:
    """Every job of the sweep of `full` (as `sweep_overrides` returns it), composed and planned, in sweep order;
    remembered for the next time (`plan_memo`)."""
    plan = plan_memo.recall(full)
    if plan is None:
        plan = [(combo, cfg, planned_stages(cfg)) for combo in job_combos(full)
                for cfg in [compose_config(combo, config_name="sweep")]]  # fmt: skip
        plan_memo.remember(full, plan)
    return [PlannedJob(combo, cfg, planned) for combo, cfg, planned in plan]
