"""What the numbers of a config may be: every command checks its composed config here before it builds anything.

A value of the wrong type or outside its range (a zero time step, a negative learning rate, a switch that is not
true or false, an object with no area) is one BadInput naming the key, the value and what is valid, before any run
dir or result is written.
Keys a config lacks (the low level has no success distance) are skipped.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from mapush.errors import BadInput, first_line
from mapush.trust import check_class_names

Rule = tuple[type, Callable[[float], bool], str]


def _at_least(low: float, what: str = "") -> Rule:
    return float, lambda v: v >= low, f"a number >= {low:g}{what}"


def _positive(what: str) -> Rule:
    return float, lambda v: v > 0, f"a positive {what}"


def _count(low: int) -> Rule:
    return int, lambda v: v >= low, f"an integer >= {low}"


SEED_MAX = 2**32 - 1
"""The largest seed: numpy's legacy `np.random.seed` (`seed_everything`) takes 32 bits; torch's generators 64."""


def _seed() -> Rule:
    return int, lambda v: 0 <= v <= SEED_MAX, f"an integer in [0, {SEED_MAX}] (numpy seeds with 32 bits)"


def _fraction(low_open: bool = False) -> Rule:
    return (
        float,
        (lambda v: 0 < v <= 1) if low_open else (lambda v: 0 <= v <= 1),
        ("a number in (0, 1]" if low_open else "a number in [0, 1]"),
    )


def _flag() -> Rule:
    return bool, lambda v: True, "true or false"


def _even_pixels() -> Rule:
    return int, lambda v: v >= 16 and v % 2 == 0, "an even integer >= 16 (px; yuv420p halves the chroma)"


RULES: dict[str, Rule] = {
    "seed": _seed(),
    "num_envs": _count(1),
    "train.iterations": _count(1),
    "train.rollout_threads": _count(0),
    "train.update_threads": _count(0),
    "sim.timestep": _positive("time step in s"),
    "sim.decimation": _count(1),
    "sim.nthread": _count(0),
    "sim.arena_size": _positive("size in m"),
    "sim.floor_friction": _at_least(0.0),
    "sim.robot_contacts": _flag(),
    "task.collision_distance": _at_least(0.0, " m"),  # runs made before robot_collision took footprints
    "level.episode_length_s": _positive("number of seconds"),
    "level.success_distance": _positive("distance in m"),
    "level.planner.max_checks": _count(1),
    "level.planner.time_limit_s": _positive("number of seconds"),
    "level.decision_steps": _count(1),
    "level.follow_path": _flag(),
    "level.action_gain": _positive("gain"),
    "level.events.push.params.interval_s": _positive("number of seconds"),
    "level.events.push.params.velocity_mps": _at_least(0.0, " m/s"),
    "level.eval_events.push.velocity_mps": _at_least(0.0, " m/s"),
    "level.events.lean.params.force_n": _at_least(0.0, " N"),
    "level.events.lean.params.duration_s": _positive("number of seconds"),
    "level.events.lean.params.interval_s": _positive("number of seconds"),
    "level.eval_events.lean.force_n": _at_least(0.0, " N"),
    "level.events.load.params.fraction": _fraction(),
    "level.events.load.params.box_size_m": _positive("size in m"),
    "level.events.load.params.cylinder_size_m": _positive("size in m"),
    "level.events.load.params.resistance_n": _positive("force in N"),
    "level.events.load.params.distance_m": _at_least(0.0, " m"),
    "level.eval_events.load.fraction": _fraction(),
    "level.events.teammates.params.fraction": _fraction(),
    "level.events.teammates.params.count": _count(1),
    "level.events.teammates.params.gap_m": _at_least(0.0, " m"),
    "level.events.teammates.params.lean_mps": _at_least(0.0, " m/s"),
    "level.eval_events.teammates.fraction": _fraction(),
    "algo.num_steps_per_env": _count(1),
    "algo.save_interval": _count(1),
    "algo.keep_checkpoints": _count(0),
    "algo.algorithm.learning_rate": _positive("learning rate"),
    "algo.algorithm.num_learning_epochs": _count(1),
    "algo.algorithm.num_mini_batches": _count(1),
    "algo.algorithm.clip_param": _positive("clip range"),
    "algo.algorithm.gamma": _fraction(low_open=True),
    "algo.algorithm.lam": _fraction(),
    "algo.algorithm.entropy_coef": _at_least(0.0),
    "algo.algorithm.value_loss_coef": _at_least(0.0),
    "algo.algorithm.max_grad_norm": _positive("gradient norm"),
    "algo.algorithm.desired_kl": _positive("KL divergence"),
    "algo.actor.distribution_cfg.std_range": _positive("std"),  # each of [low, high]
    "eval.episodes": _count(1),
    "eval.seeds": _seed(),
    "log.tensorboard": _flag(),
    "log.video_interval": (int, lambda v: v >= 0, "an integer >= 0 (iterations; 0 = no training videos)"),
    "log.video.width": _even_pixels(),
    "log.video.height": _even_pixels(),
    "log.video.episodes": _count(1),
    "log.video.fps": _positive("number of frames per second of sim time (at most one per env step is drawn)"),
    "log.video.speedup": _positive("playback speed (1: real time, 2: twice as fast)"),
    "log.video.max_seconds": _positive("number of seconds of sim time per file"),
    "log.video.crf": (int, lambda v: 0 <= v <= 51, "an integer in [0, 51] (H.264 quality, lower is better)"),
}
"""Every checked value: key -> (type, test, what is valid); for a list, of each item."""
NAMES = ("task.name", "level.name", "lowlevel.name")
"""Keys that name things (and so run dirs): one word each, never a path or a mapping."""
NAME_LENGTH = 64
"""The longest name (`NAMES`, `mapush eval --name`): a part of a file name, well inside a filesystem's 255 bytes."""


def check_config(cfg: DictConfig | dict, task_weights: set[str] | None = None) -> None:
    """BadInput for the first value of `cfg` that breaks `RULES` or describes an impossible object, or (given the
    keys the reward files read, `task_weight_names`) a task weight that no reward term reads."""
    cfg = cfg if isinstance(cfg, DictConfig) else OmegaConf.create(cfg)
    absent = object()
    for key, (kind, test, valid) in RULES.items():
        value = OmegaConf.select(cfg, key, default=absent, throw_on_missing=False)
        if value is absent or value is None:
            continue
        for item in value if OmegaConf.is_list(value) else [value]:  # a list's rule holds for each of its items
            _check_value(key, item, kind, test, valid)
    obj = OmegaConf.select(cfg, "task.object", default=None)
    if obj is not None:
        check_object(obj)
    for name, term in (OmegaConf.select(cfg, "reward.terms", default=None) or {}).items():
        if term is not None and "weight" in term:  # a NaN weight would make every total NaN, then zero
            _check_value(f"reward.terms.{name}.weight", term.weight, float, lambda v: True, "a finite number")
    if task_weights is not None:
        check_task_weights(cfg, task_weights)
    for key in NAMES:
        value = OmegaConf.select(cfg, key, default=None, throw_on_missing=False)
        plain = isinstance(value, str) and value.replace("_", "").replace("-", "").isalnum()
        if value is not None and not (plain and len(value) <= NAME_LENGTH):
            shown = value if not plain or len(value) <= 80 else f"{value[:60]}... ({len(value)} characters)"
            raise BadInput(
                f"{key}={shown!r} is not valid; valid: a name of letters, digits, - and _ (1 to {NAME_LENGTH})"
            )
    algo = OmegaConf.select(cfg, "algo", default=None)
    if algo is not None and "logger" in algo:  # the runner sets it: another value would be silently replaced
        raise BadInput(
            f"algo.logger={OmegaConf.select(algo, 'logger', throw_on_missing=False)!r} is set by mapush (metrics "
            "always go to metrics.mcap); valid: leave algo.logger out, and add log.tensorboard=true for TensorBoard"
        )
    if algo is not None:  # as written (no interpolation may name code) and as rsl-rl will read it
        check_class_names("algo", OmegaConf.to_container(algo), resolved=False)
        try:
            resolved = OmegaConf.to_container(algo, resolve=True)
        except Exception as err:  # OmegaConf's interpolation errors have several types
            raise BadInput(f"algo does not resolve ({first_line(err)})") from None
        check_class_names("algo", resolved)


TASK_WEIGHT = re.compile(r"task\.reward_weights\.(\w+)")
"""How a reward file reads a task's own weight of a term (`${oc.select:task.reward_weights.NAME,...}`)."""


def task_weight_names(conf_dirs) -> set[str]:
    """The `task.reward_weights` keys that some reward file (`<dir>/reward/*.yaml`) of `conf_dirs` reads."""
    files = (f for d in conf_dirs for f in sorted(Path(d).glob("reward/*.yaml")))
    return {name for f in files for name in TASK_WEIGHT.findall(f.read_text())}


def check_task_weights(cfg: DictConfig, readable: set[str]) -> None:
    """BadInput for a `task.reward_weights` key that no reward file reads (a typo would weigh nothing)."""
    unknown = sorted(set(OmegaConf.select(cfg, "task.reward_weights", default=None) or {}) - readable)
    if unknown:
        raise BadInput(
            f"task.reward_weights.{unknown[0]} is read by no reward term; valid: {', '.join(sorted(readable))}"
        )


def _check_value(key: str, value, kind: type, test: Callable, valid: str) -> None:
    if kind is bool:
        typed = isinstance(value, bool)
    else:
        numeric = isinstance(value, (int, float) if kind is float else int) and not isinstance(value, bool)
        typed = numeric and math.isfinite(value)
    if not typed or not test(value):
        raise BadInput(f"{key}={value!r} is not valid; valid: {valid}")


def check_object(obj) -> None:
    """The object's parts have positive sizes and masses, and its hull (if given) encloses an area."""
    parts = obj.get("parts") or []
    if not parts:
        raise BadInput("task.object.parts is empty; valid: one or more {type: box|cylinder, size, pos, mass}")
    for i, part in enumerate(parts):
        where = f"task.object.parts[{i}]"
        size = list(part.get("size") or [])
        if part.get("type") not in ("box", "cylinder"):
            raise BadInput(f"{where}.type={part.get('type')!r} is not valid; valid: box, cylinder")
        wanted = 3 if part["type"] == "box" else 2
        if len(size) != wanted or not all(_is_number(s) and s > 0 for s in size):
            shape = "[x, y, z] full extents" if wanted == 3 else "[radius, height]"
            raise BadInput(f"{where}.size={size!r} is not valid; valid: {wanted} positive numbers, {shape} in m")
        _check_value(f"{where}.mass", part.get("mass"), float, lambda v: v > 0, "a positive mass in kg")
    if obj.get("mass") is not None:
        _check_value("task.object.mass", obj.get("mass"), float, lambda v: v > 0, "a positive mass in kg, or null")
    span = obj.get("mass_range")
    listed = OmegaConf.is_list(span) or isinstance(span, list | tuple)
    if span is not None and not (
        listed and len(span) == 2 and all(_is_number(m) and m > 0 for m in span) and float(span[0]) <= float(span[1])
    ):
        shown = list(span) if listed else span
        raise BadInput(
            f"task.object.mass_range={shown!r} is not valid; valid: [low, high] kg with 0 < low <= high, or null"
        )
    if span is not None and obj.get("mass") is not None:
        raise BadInput("task.object.mass and task.object.mass_range are both set; valid: one of them, or neither")
    hull = obj.get("hull")
    if hull is not None and polygon_area(hull) <= 1e-9:
        raise BadInput(
            f"task.object.hull={OmegaConf.to_container(hull) if OmegaConf.is_config(hull) else hull!r} encloses "
            "no area; valid: null (the footprint's convex hull) or 3+ [x, y] corners of a counter-clockwise polygon"
        )


def polygon_area(points) -> float:
    """Signed area of a polygon (shoelace formula; positive when counter-clockwise); 0 if it is not one."""
    try:
        xy = [(float(x), float(y)) for x, y in points]
    except (TypeError, ValueError):
        return 0.0
    if len(xy) < 3:
        return 0.0
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(xy, xy[1:] + xy[:1], strict=True))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
