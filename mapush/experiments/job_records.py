"""What a job's result holds of its evaluations and learning curves, as typed records (`Evaluation`, `Curve`).

An evaluation is the summary `mapush eval` writes (`eval.json`, less its per-seed rows) with where it came from;
a curve is a stage's checkpoints evaluated at marks of its env-steps (`pipeline`), with the rule that judges
whether its budget was enough. Each reads its part of `result.json` (`from_record`) and writes it back
(`record`) as it was: a key the record does not name as a field (a level's own figures, the machine, the code's
version) is kept in `also`, as written.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TypedDict

from mapush.errors import BadInput


@dataclass(frozen=True)
class EventShare:
    """How often an event (a fall, robots touching, the object tilted) happened: the share of episodes with one and
    the mean count per episode."""

    episode_share: float
    per_episode: float | None = None


@dataclass
class Evaluation:
    """One evaluation of a job's policy: rates over its episodes and seeds (success, completion time as a share of
    the timeout and in seconds), what ended episodes (`exceptions`, shares by name) and what happened in them
    (`events`), the object's mass it ran at, and what it evaluated (checkpoint, overrides, episodes, seeds)."""

    success_rate: float
    success_rate_std: float | None = None
    completion_time: float | None = None
    completion_time_std: float | None = None
    completion_time_s: float | None = None
    timeout_s: float | None = None
    path_length_m: float | None = None
    object_mass_kg: float | None = None
    exceptions: dict[str, float] | None = None
    events: dict[str, EventShare] | None = None
    episodes: int | None = None
    seeds: list[int] | None = None
    checkpoint: str | None = None
    file: str | None = None
    overrides: list[str] | None = None
    task: str | None = None
    num_agents: int | None = None
    lowlevel_policy: dict[str, str] | None = None  # the locomotion policy that walked the robots (its fingerprint)
    also: dict[str, object] = field(default_factory=dict)  # the record's other keys, as written

    @classmethod
    def from_record(cls, record: dict) -> Evaluation:
        known = {f.name for f in dataclasses.fields(cls)} - {"also"}
        given = {k: v for k, v in record.items() if k in known}
        if given.get("events") is not None:
            given["events"] = {name: EventShare(**share) for name, share in given["events"].items()}
        return cls(**given, also={k: v for k, v in record.items() if k not in known})

    def record(self) -> dict:
        """As `result.json` holds it: the fields that are set, then the other keys."""
        out = {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.name != "also" and getattr(self, f.name) is not None
        }
        if self.events is not None:
            out["events"] = {name: _set_fields(share) for name, share in self.events.items()}
        return {**out, **self.also}

    def metric(self, name: str) -> float | None:
        """A rate or time by its field name (a table's column names it); None where this evaluation lacks it."""
        value = getattr(self, name)
        return None if value is None else float(value)


class CurvePoint(TypedDict, total=False):
    """One evaluated checkpoint of a learning curve, as `mapush.eval.curves.learning_curve` draws it: its
    iteration and env-steps, and the evaluation's success rate (and its std and completion time)."""

    iteration: int
    env_steps: float
    success_rate: float
    success_rate_std: float
    completion_time: float


@dataclass(frozen=True)
class CurveRule:
    """When a budget is enough: the last `tail` share of the curve's env-steps adds less than `max_gain` success."""

    tail: float
    max_gain: float


@dataclass
class Curve:
    """A learning curve: `points` drawn every `every_env_steps` as evaluation `eval` (the evaluated stage's) or on
    the stage's own env (`episodes`, `seeds`: a stage trained under the evaluated one), the success rate `reach`
    it is timed to, the stages whose own curves the budget asks for (`stages`), and its budget `rule`."""

    points: list[CurvePoint]
    eval: str | None = None
    every_env_steps: float | None = None
    reach: float | None = None
    rule: CurveRule | None = None
    stages: dict[str, dict] | None = None
    episodes: int | None = None
    seeds: list[int] | None = None

    @classmethod
    def from_record(cls, record: dict | Curve | None) -> Curve | None:
        if record is None or isinstance(record, Curve):
            return record
        unknown = sorted(set(record) - {f.name for f in dataclasses.fields(cls)})
        if unknown:
            raise BadInput(f"a learning curve has unknown keys {unknown}; valid: {sorted(CURVE_KEYS)}")
        rule = record.get("rule")
        return cls(**{**record, "rule": None if rule is None else CurveRule(**rule)})

    def record(self) -> dict:
        return _set_fields(self)


CURVE_KEYS = {f.name for f in dataclasses.fields(Curve)}


def _set_fields(record) -> dict:
    """A dataclass as a dict of its fields that are set (nested dataclasses too)."""
    return {k: v for k, v in dataclasses.asdict(record).items() if v is not None}
