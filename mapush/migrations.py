"""Old files, read as today's: the one place that knows what mapush's files looked like before.

The files mapush writes for later reading carry `format_version` (`FORMAT_VERSION`): a run's `meta.json`, a sweep
job's `result.json` and a stage's `stage.yaml`. A file without it was written before the key existed (version 0).
Readers pass what they read through `upgrade`, which brings it to today's version one step at a time (`STEPS`), so
that no other module tests for an old form.

A run's saved `config.yaml` in an old form is rewritten to today's form when it is read (`upgrade_run_config`):
the low level's disturbances, once keys of `level.randomize` and `level.eval_*`, are event terms since
2026-11-29 (`level.events`, `level.eval_events`); the level that trains the Go1's locomotion policy, once
`level=low` (`mapush/envs/low.py`, its rewards in `mapush/rewards/locomotion.py`), is `level=locomotion` since
2026-12-07 (`RENAMED_LEVELS`, `RENAMED_MODULES`; the rewards are in `mapush/rewards/legged.py`), so that "low" names
one thing: the robot under the mid level (`lowlevel=`).

Two kinds of change live in the config instead, as keys whose absence has a meaning:
- a key added after runs were made, with the value that leaves those runs as they were (`UNSET_LATER_KEYS`): at
  that value a stage's identity leaves the key out, so the stages trained before it keep theirs;
- a key whose default changed after it was added (`ABSENT_MEANT`): a run saved without it ran with the old value,
  which `load_run_config` gives it (`absent_meant`).
"""

from __future__ import annotations

from collections.abc import Callable

from omegaconf import DictConfig, OmegaConf

from mapush.errors import BadInput

FORMAT_VERSION = 1
"""Today's version of meta.json, result.json and stage.yaml."""

UNSET_LATER_KEYS = {
    "train.init_from": None,
    "lowlevel.randomize": None,
    "sim.robot_contacts": True,
    "task.reward_weights.robot_jam": 0.0,  # a task that switches the term off (T-block, cylinder, OCB cuboid)
    "level.planner.max_checks": 50000,  # the planner's work budget; plans before it ended on first solutions too
    "lowlevel.force_cap": "axes",  # the tracker's cap on each world axis, as before the planar cap
    "lowlevel.fall": None,  # a tracker that cannot fall, as before the load-to-fall model
    "task.object.mass": None,  # the object's mass set apart from its parts' (the team study)
    "task.object.mass_range": None,  # the object's mass drawn per episode (the team study)
    "level.action_gain": 1.0,  # the mid level's raw actions clipped as they are, as before the gain
    "level.rules": "strict",  # the rules each level's own file states (conf/rules/), as before `rules=`
    "level.fallen_robots": "act",  # a fallen robot keeps its commands, as before `fallen_robots`
}
"""Keys added after stages were trained, with the value that leaves a stage as it was: at that value a key stays
out of a stage's identity (and so does a parent it leaves empty), so the stages trained before it existed keep
theirs; set otherwise, it makes another stage (`mapush.experiments.stages.identity`)."""

ABSENT_MEANT = {"level.path.plan_in_training": False}
"""Settings whose default changed after they were added: a run saved before one existed ran as this value."""


def _from_version_0(data: dict) -> dict:
    """Version 0 files hold everything version 1 files do; version 1 only names its version."""
    return data


STEPS: dict[int, Callable[[dict], dict]] = {0: _from_version_0}
"""`STEPS[v]` turns a version-v file's content into version v + 1's."""


def stamp(data: dict) -> dict:
    """`data` as written today: with `format_version`."""
    return {**data, "format_version": FORMAT_VERSION}


def upgrade(data: dict, what: str) -> dict:
    """A file's content (`what` names it in a message) brought to today's `FORMAT_VERSION`; BadInput for a file a
    newer mapush wrote, or one that is not a record or names no version mapush knows."""
    if not isinstance(data, dict):
        raise BadInput(f"{what} holds a {type(data).__name__}, not a record; valid: the file as mapush wrote it")
    version = data.get("format_version", 0)
    if not isinstance(version, int) or isinstance(version, bool) or version < 0:
        raise BadInput(
            f"{what} has format_version {version!r}, which no mapush wrote; valid: an integer from 0 to "
            f"{FORMAT_VERSION}"
        )
    if version > FORMAT_VERSION:
        raise BadInput(
            f"{what} has format_version {version}, newer than this mapush reads ({FORMAT_VERSION}); valid: files of "
            f"format_version {FORMAT_VERSION} or less (a newer mapush reads this one)"
        )
    while version < FORMAT_VERSION:
        data = STEPS[version](data)
        version += 1
    return stamp(data)


EVENT_KEYS = {
    "randomize.push_interval_s": ("events", "push", "interval_s"),
    "randomize.push_velocity": ("events", "push", "velocity_mps"),
    "randomize.force_n": ("events", "lean", "force_n"),
    "randomize.force_duration_s": ("events", "lean", "duration_s"),
    "randomize.force_interval_s": ("events", "lean", "interval_s"),
    "randomize.load": ("events", "load", None),
    "randomize.teammates": ("events", "teammates", None),
    "eval_push_velocity": ("eval_events", "push", "velocity_mps"),
    "eval_force_n": ("eval_events", "lean", "force_n"),
    "eval_load_fraction": ("eval_events", "load", "fraction"),
    "eval_teammate_fraction": ("eval_events", "teammates", "fraction"),
}
"""Keys of a low-level run's `level` before its disturbances were event terms, and where each went: (section,
event, param), param None for a block that became the event's params. An event's `func` comes from today's
defaults, which a run's saved config is merged onto."""


RETIRED_KEYS = ("log.video.max_frames",)
"""Settings runs saved that mapush reads no more, dropped on load: a video's length is `log.video.max_seconds` of sim
time now, not frames at one per env step (saved runs hold 1500: 30 s, shorter than a high-level episode)."""


RENAMED_LEVELS = {"low": "locomotion"}
"""`level.name`s a run saved that are another name today."""
RENAMED_MODULES = {
    "mapush.envs.low:": "mapush.envs.locomotion:",
    "mapush.envs.low_events:": "mapush.envs.locomotion_events:",
    "mapush.rewards.locomotion:": "mapush.rewards.legged:",
}
"""Term modules (`func: module:name`) a run saved as a renamed level that moved with it, by their prefix."""


def upgrade_run_config(run: DictConfig) -> DictConfig:
    """A run's saved config in today's form (`RETIRED_KEYS`, `RENAMED_LEVELS`, `RENAMED_MODULES`, `EVENT_KEYS`); a
    config already in it is returned as it is."""
    run = _renamed(run)
    if any(OmegaConf.select(run, key, default=None) is not None for key in RETIRED_KEYS):
        run = run.copy()
        for key in RETIRED_KEYS:
            parent, _, leaf = key.rpartition(".")
            OmegaConf.select(run, parent).pop(leaf, None)
    level = run.get("level")
    if level is None or not any(OmegaConf.select(level, key) is not None for key in EVENT_KEYS):
        return run
    run = run.copy()
    for key, (section, event, param) in EVENT_KEYS.items():
        parent, _, leaf = key.rpartition(".")
        node = OmegaConf.select(run.level, parent) if parent else run.level
        if node is None or leaf not in node:
            continue
        value = node.pop(leaf)
        target = f"level.{section}.{event}" + (".params" if section == "events" else "")
        if param is None:
            OmegaConf.update(run, target, value, merge=True, force_add=True)
        else:
            OmegaConf.update(run, f"{target}.{param}", value, force_add=True)
    return run


def _renamed(run: DictConfig) -> DictConfig:
    """`run` with a renamed level's name and its terms' moved modules (any section's: the level's, the reward's) as
    they are today; a copy where it changes."""
    level = run.get("level")
    if level is None or level.get("name") not in RENAMED_LEVELS:
        return run
    plain = OmegaConf.to_container(run, resolve=False)

    def moved(node):
        if isinstance(node, dict):
            return {key: moved(value) for key, value in node.items()}
        if isinstance(node, list):
            return [moved(value) for value in node]
        if isinstance(node, str):
            for old, new in RENAMED_MODULES.items():
                if node.startswith(old):
                    return new + node[len(old) :]
        return node

    plain = moved(plain)
    plain["level"]["name"] = RENAMED_LEVELS[plain["level"]["name"]]
    return OmegaConf.create(plain)


def absent_meant(saved: DictConfig, cfg: DictConfig) -> None:
    """Set in `cfg` (a run's config as loaded) the `ABSENT_MEANT` keys that the run's `saved` config lacks, where it
    has their parent: the run ran with the old default."""
    for key, value in ABSENT_MEANT.items():
        parent, _, leaf = key.rpartition(".")
        node = OmegaConf.select(saved, parent)
        if node is not None and leaf not in node:
            OmegaConf.update(cfg, key, value)
