"""The physics a job's tables weigh its cells by, as typed data: the pushed object's mass and floor friction, and
what one robot pushes (`ObjectPhysics`); and the mass each evaluation set.

A team is needed only where an object's drag exceeds what one robot pushes. The drag is mass x g x the task's
friction range; one robot's capacity is the tracker's at the mid level's largest command, the lesser of its force
cap and its velocity loop's stall force (mass / lag x speed), which `mapush calibrate` fits to the legged Go1. A job
records these when it finishes (`pipeline.run_job`); for a job recorded before, they are read from the composed
config its stages' records hold (`stage.yaml`), so no table composes a config or parses an override.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

from hydra.core.override_parser.overrides_parser import OverridesParser

from mapush.experiments import stages
from mapush.lowlevel import backend_name

G = 9.81
"""m/s^2."""
MASS, MASS_RANGE = "task.object.mass", "task.object.mass_range"
"""The keys that set an object's mass, fixed or drawn per episode (the team study's)."""


PUSHING_STAGE = "mid"
"""The stage of a method (`conf/method/`) that pushes the object: its commands are what a robot's capacity is
taken at."""


def _parse(text: str):
    """One override as Hydra's grammar reads it (the parser built once: the team table asks for every job)."""
    return _parser().parse_override(text)


@functools.cache
def _parser() -> OverridesParser:
    return OverridesParser.create()


@dataclass(frozen=True)
class ObjectPhysics:
    """The object a job's policy trained on and one of its robots: `mass_kg` (fixed: its `mass`, else its parts'),
    `mass_range_kg` (drawn per episode in training; None: fixed), `friction` (the floor friction range) and
    `robot_capacity_n` (one tracker's push at the mid level's largest command; None for a legged low level,
    whose capacity is `mapush calibrate`'s measurement)."""

    mass_kg: float
    friction: tuple[float, float]
    mass_range_kg: tuple[float, float] | None = None
    robot_capacity_n: float | None = None

    def drag_n(self, mass_kg: float | None = None) -> tuple[float, float]:
        """N; the least and greatest floor drag of the object at its mass (or `mass_kg`)."""
        mass = self.mass_kg if mass_kg is None else mass_kg
        return mass * G * self.friction[0], mass * G * self.friction[1]

    def record(self) -> dict:
        return {
            "mass_kg": self.mass_kg,
            "friction": list(self.friction),
            "mass_range_kg": None if self.mass_range_kg is None else list(self.mass_range_kg),
            "robot_capacity_n": self.robot_capacity_n,
        }

    @classmethod
    def from_record(cls, record: dict | None) -> ObjectPhysics | None:
        if record is None:
            return None
        ranged = record.get("mass_range_kg")
        return cls(
            float(record["mass_kg"]),
            (float(record["friction"][0]), float(record["friction"][1])),
            None if ranged is None else (float(ranged[0]), float(ranged[1])),
            record.get("robot_capacity_n"),
        )


def object_physics(cfg: dict, pushes: bool) -> ObjectPhysics:
    """A composed (plain) stage config's object, and its robot's capacity where the stage `pushes` (a job's mid
    stage: its `level.action_scale` is the largest command a robot is given) on the tracker."""
    obj = cfg["task"]["object"]
    low, high = obj["friction"] if isinstance(obj["friction"], list | tuple) else (obj["friction"],) * 2
    ranged = obj.get("mass_range")
    capacity = None
    if pushes and backend_name(cfg["lowlevel"]) == "tracker":  # a calibrated tracker of yours too
        capacity = tracker_capacity(cfg["lowlevel"], float(cfg["level"]["action_scale"][0]))
    return ObjectPhysics(
        float(obj.get("mass") or sum(part["mass"] for part in obj["parts"])),
        (float(low), float(high)),
        None if ranged is None else (float(ranged[0]), float(ranged[1])),
        capacity,
    )


def tracker_capacity(lowlevel: dict, speed: float) -> float:
    """N; the most one tracker pushes at a standstill when told `speed` (m/s): its velocity loop's stall force
    mass / lag x speed, capped at `max_force` (on the planar norm; a push straight along one axis under `axes`)."""
    return min(float(lowlevel["max_force"]), float(lowlevel["mass"]) / float(lowlevel["lag"]) * speed)


def evaluated_mass(physics: ObjectPhysics, overrides: list[str]) -> float | None:
    """kg; the object's one mass in an evaluation of a job made on `physics` under `overrides` (the team study's
    `task.object.mass_range=null task.object.mass=M`): the trained mass where they set none; None where the mass
    is drawn per episode (a range the overrides leave on or set) or not known (its `mass` removed or null: the
    parts' own, which `physics` does not hold apart)."""
    ranged, mass = physics.mass_range_kg is not None, physics.mass_kg
    for override in map(_parse, overrides):
        cleared = override.is_delete() or override.value() is None
        if override.key_or_group == MASS_RANGE:
            ranged = not cleared
        elif override.key_or_group == MASS:
            mass = None if cleared else float(override.value())
    return None if ranged else mass


def stage_config(result, name: str) -> dict | None:
    """The composed config of a job's stage `name`, from its record in the store its run lies in; None where the
    record is gone (a run outside a store, an archive without it)."""
    runs = dict(zip(result.stages, result.stage_runs(), strict=True))
    run = runs.get(name)
    root = run and stages.store_root(run)
    if root is None:
        return None
    record = stages.stage_dir(root, stages.identity_of(run)) / stages.IDENTITY_FILE
    return stages.stage_record(record).get("config") if record.is_file() else None


def physics_from_stages(result) -> ObjectPhysics | None:
    """`ObjectPhysics` of a job recorded before jobs recorded it: its mid level's stage config (the stage that pushes
    and whose commands a robot's capacity is taken at), else its first stage's."""
    name = PUSHING_STAGE if PUSHING_STAGE in result.stages else next(iter(result.stages), None)
    cfg = stage_config(result, name) if name else None
    return None if cfg is None else object_physics(cfg, pushes=name == PUSHING_STAGE)


def trained_mass(result) -> float | None:
    """kg; the one mass a job's policy trained at: from its physics, or where no stage record holds them, from its
    stage overrides (`task.object.mass_range=null task.object.mass=M`); None where it trained over a range or the
    records are gone and its overrides set no one mass."""
    physics = result.object_physics()
    if physics is not None:
        return None if physics.mass_range_kg is not None else physics.mass_kg
    given = {o.key_or_group: o for o in map(_parse, map(str, result.overrides))}
    fixed = MASS_RANGE in given and given[MASS_RANGE].value() is None and MASS in given
    return float(given[MASS].value()) if fixed and given[MASS].value() is not None else None


def sets_mass(override: str) -> bool:
    """Whether a stage override sets the object's mass (fixed or drawn)."""
    return _parse(override).key_or_group in (MASS, MASS_RANGE)


def besides_mass(overrides: list[str]) -> tuple[str, ...]:
    """A job's stage overrides other than those that set the object's mass, sorted: what else it was made with."""
    return tuple(sorted(str(o) for o in overrides if not sets_mass(str(o))))
