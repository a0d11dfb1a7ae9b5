"""A sweep job's record (`JobResult`): `result.json` in its job dir, and the earlier result a rerun keeps beside
it. Read and written here only, so that every reader gets today's form (`migrations.upgrade`) as typed fields."""

from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from mapush.atomic import write_json
from mapush.errors import BadInput
from mapush.experiments import stages
from mapush.experiments.job_physics import (
    ObjectPhysics,
    besides_mass,
    evaluated_mass,
    physics_from_stages,
    trained_mass,
)
from mapush.experiments.job_records import Curve, Evaluation
from mapush.migrations import stamp, upgrade
from mapush.records import check_schema, read_json

RESULT = "result.json"
"""A finished job's record, written by `run_job`, read by `read_result`."""

SUPERSEDED = "result.superseded.json"
"""Where a job's earlier result goes when the experiment changed under it (`result_changes`)."""

ARCHIVED_FROM = "archived_from"
"""The field of an archived result that names the job dir it was copied from (`mapush archive`)."""


NUMBER, INTEGER, TEXT = {"type": "number"}, {"type": "integer"}, {"type": "string"}


def _nullable(schema: dict) -> dict:
    """`schema`, or null (the keywords of an object's schema apply to objects only)."""
    return {**schema, "type": ["null", schema["type"]]}


def _record(properties: dict, required: tuple[str, ...] = (), closed: bool = False) -> dict:
    """An object's schema; `closed`: no keys but `properties` (a typed record's, `job_records.py`)."""
    schema = {"type": "object", "properties": properties, "required": list(required)}
    return {**schema, "additionalProperties": False} if closed else schema


POINT = _record({"iteration": INTEGER, "env_steps": NUMBER, "success_rate": NUMBER}, ("env_steps", "success_rate"))
CURVE = _record(
    {
        **{"eval": TEXT, "every_env_steps": NUMBER, "reach": NUMBER, "episodes": INTEGER},
        "rule": _record({"tail": NUMBER, "max_gain": NUMBER}, ("tail", "max_gain"), closed=True),
        "points": {"type": "array", "items": POINT},
        "stages": {"type": "object", "additionalProperties": {"type": ["object", "null"]}},
        "seeds": {"type": "array", "items": INTEGER},
    },
    ("points",),
    closed=True,
)
PAIR = {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 2}
PHYSICS = _record(
    {"mass_kg": NUMBER, "friction": PAIR, "mass_range_kg": _nullable(PAIR), "robot_capacity_n": _nullable(NUMBER)},
    ("mass_kg", "friction"),
    closed=True,
)
EVENT = _record({"episode_share": NUMBER, "per_episode": NUMBER}, ("episode_share",), closed=True)
EVAL = _record(
    {
        **dict.fromkeys(("success_rate", "completion_time", "completion_time_s", "timeout_s", "path_length_m"), NUMBER),
        **dict.fromkeys(("success_rate_std", "completion_time_std", "object_mass_kg"), NUMBER),
        "exceptions": {"type": "object", "additionalProperties": NUMBER},
        "events": {"type": "object", "additionalProperties": EVENT},
        "episodes": INTEGER,
        "seeds": {"type": "array", "items": INTEGER},
        "checkpoint": TEXT,
        "overrides": {"type": "array", "items": TEXT},
    },
    ("success_rate",),
)
RECORD = _record(
    {
        **dict.fromkeys(("experiment", "table", "budget", "variant", "method", "method_label", "task"), TEXT),
        "finished": TEXT,
        **dict.fromkeys(("supersedes", "archived_from", "taken_from"), _nullable(TEXT)),
        "overrides": {"type": "array", "items": TEXT},
        "num_agents": INTEGER,
        "seed": INTEGER,
        **dict.fromkeys(("rules", "lowlevel"), _nullable(TEXT)),
        "stages": {"type": "object", "additionalProperties": TEXT},
        "stage_core_s": {"type": "object", "additionalProperties": NUMBER},
        "evals": {"type": "object", "additionalProperties": EVAL},
        "curve": _nullable(CURVE),
        "stage_curves": _nullable({"type": "object", "additionalProperties": _nullable(CURVE)}),
        "eval_wall_s": _nullable(NUMBER),
        **dict.fromkeys(("threads", "machine_cores"), _nullable(INTEGER)),
        "physics": _nullable(PHYSICS),
    }
)
"""What the tables read of a result (`read_result`), as JSON Schema: each field's type (its numbers are finite:
`read_json` refuses the others), a curve's points (and its rule whole, where given) and an evaluation's success rate
present (another metric it lacks leaves its cell empty); a field of another type is one line naming the file and
the field."""


@dataclass(frozen=True)
class Change:
    """Why a finished result no longer stands for what its experiment plans now (`result_changes`): `kind`, the
    stages whose identity changed (`stages`, in the plan's order) or the one evaluation it is about
    (`evaluation`), and `text`, the change in words as the sweep and the tables print it."""

    kind: Literal["stages", "evaluations", "evaluation", "curve"]
    text: str
    stages: tuple[str, ...] = ()
    evaluation: str | None = None

    def __str__(self) -> str:
        return self.text

    @classmethod
    def from_record(cls, record: dict | None) -> Change | None:
        """A change as `dataclasses.asdict` wrote it to JSON (its stages a list), None for none."""
        return record and cls(**{**record, "stages": tuple(record["stages"])})

    def concerns(self, result: JobResult, name: str) -> bool:
        """Whether the change concerns the result's evaluation `name`, so that a table marks its cells: a changed
        evaluation concerns only itself; changed stages concern the evaluations of those stages and of every stage
        after them in the plan (trained on them), not a mid level evaluated alone whose high level alone changed;
        any other change (the set of evaluations, the curve) the whole job."""
        if self.kind == "evaluation":
            return self.evaluation == name
        evaluated = result.evaluated_stage(name)
        return evaluated is None or self.concerns_stage(result, evaluated)

    def concerns_stage(self, result: JobResult, stage: str) -> bool:
        """Whether the change concerns what the result's `stage` learned (its own curve): changed stages when one
        of them is that stage or comes before it in the plan; a changed evaluation never; any other change always."""
        if self.kind != "stages":
            return self.kind != "evaluation"
        order = list(result.stages)
        return any(s not in order or order.index(s) <= order.index(stage) for s in self.stages)


@dataclass
class JobResult:
    """What one sweep job made: which job it is, the stage runs it trained or reused, its evaluations and learning
    curves, and what they cost. The fields before `job_dir` are the file's; an absent optional one is None.

    `evals` maps an evaluation's name to its `Evaluation` (the summary `mapush eval` wrote, with its `file` and
    `overrides`); `curve` and `stage_curves` are `Curve`s as `pipeline` draws them (`job_records.py`)."""

    experiment: str = ""
    table: str = ""
    budget: str = ""
    variant: str = ""  # the budget, and the sweep's extra stage overrides if any: tables never mix variants
    overrides: list[str] = field(default_factory=list)  # extra overrides for every stage
    method: str = ""
    method_label: str = ""
    task: str = ""
    num_agents: int = 0
    seed: int = 0
    rules: str | None = None  # the rules its stages were trained under (`level.rules`); None: before they were named
    lowlevel: str | None = None  # the low level its stages were trained on (`lowlevel.name`); None: not recorded
    stages: dict[str, str] = field(default_factory=dict)  # stage name -> run dir, in training order
    stage_core_s: dict[str, float] = field(default_factory=dict)  # training core-seconds, kept when runs are gone
    evals: dict[str, Evaluation] = field(default_factory=dict)
    curve: Curve | None = None  # the evaluated stage's learning curve, if the budget asks for one
    stage_curves: dict[str, Curve | None] | None = None  # the curves of stages trained under it, by stage name
    eval_wall_s: float | None = None  # this job's time after training (None: finished before it was recorded)
    threads: int | None = None
    machine_cores: int | None = None
    finished: str = ""  # ISO time
    supersedes: str | None = None  # the earlier result this one replaced (`SUPERSEDED`), beside it
    archived_from: str | None = None  # the job dir `mapush archive` copied it from
    taken_from: str | None = None  # another sweep's job of the same stages and evaluations, this one's source
    physics: ObjectPhysics | None = None  # its object and one robot (`job_physics`); None: made before recorded
    # not in the file: where it was read, and what `mapush tables` found of it against its experiment now
    job_dir: str = field(default="", metadata={"in_file": False})
    made_otherwise: Change | None = field(default=None, metadata={"in_file": False})
    physics_read: bool = field(default=False, metadata={"in_file": False}, repr=False, compare=False)
    runs_found: tuple | None = field(default=None, init=False, metadata={"in_file": False}, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Evaluations and curves given as their records (`result.json`'s, or a job's as it makes them) become
        typed."""
        self.evals = {name: _evaluation(e) for name, e in self.evals.items()}
        self.curve = Curve.from_record(self.curve)
        if self.stage_curves is not None:
            self.stage_curves = {name: Curve.from_record(c) for name, c in self.stage_curves.items()}

    @classmethod
    def from_record(cls, record: dict, job_dir: str | Path = "") -> JobResult:
        """A result from its file's content (today's form), read from `job_dir`."""
        names = {f.name for f in dataclasses.fields(cls) if f.metadata.get("in_file", True)}
        unknown = sorted(set(record) - names - {"format_version"})
        if unknown:
            raise BadInput(f"result in {job_dir or 'a record'} has unknown fields {unknown}; valid: {sorted(names)}")
        fields = {k: v for k, v in record.items() if k in names}
        fields["physics"] = ObjectPhysics.from_record(record.get("physics"))
        return cls(**fields, job_dir=str(job_dir))

    def record(self) -> dict:
        """The file's content: its fields in order, the optional ones only when set."""
        optional = {"stage_curves", "eval_wall_s", "supersedes", "archived_from", "taken_from", "rules", "lowlevel"}
        optional.add("physics")
        record = {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.metadata.get("in_file", True) and not (f.name in optional and getattr(self, f.name) is None)
        }
        if self.physics is not None:
            record["physics"] = self.physics.record()
        record["evals"] = {name: e.record() for name, e in self.evals.items()}
        record["curve"] = self.curve and self.curve.record()
        if self.stage_curves is not None:
            record["stage_curves"] = {name: c and c.record() for name, c in self.stage_curves.items()}
        return record

    def object_physics(self) -> ObjectPhysics | None:
        """Its object and one robot: as recorded, else (a job made before jobs recorded them) from its stages'
        records (`job_physics.physics_from_stages`); None where neither holds them."""
        if self.physics is None and not self.physics_read:  # read once, found or not
            self.physics, self.physics_read = physics_from_stages(self), True
        return self.physics

    def object_mass(self, name: str) -> float | None:
        """kg; the object's mass in its evaluation `name`: as recorded, else from its physics and the evaluation's
        overrides (`job_physics.evaluated_mass`); None where neither is known."""
        evaluation, physics = self.evals.get(name), self.object_physics()
        if evaluation is None or evaluation.object_mass_kg is not None or physics is None:
            return None if evaluation is None else evaluation.object_mass_kg
        return evaluated_mass(physics, evaluation.overrides or [])

    def trained_mass_kg(self) -> float | None:
        """kg; the one mass its policy trained at (`job_physics.trained_mass`); None where it trained over a range or
        that is not known."""
        return trained_mass(self)

    def made_besides_mass(self) -> tuple[str, ...]:
        """Its stage overrides other than those that set the object's mass, sorted: what else it was made with."""
        return besides_mass(self.overrides)

    def sets_mass(self) -> bool:
        """Whether its stage overrides set the object's mass (one mass or a range): trained at another than its
        task's."""
        return len(self.made_besides_mass()) < len(self.overrides)

    def evaluated_stage(self, name: str) -> str | None:
        """The stage whose run its evaluation `name` loaded the checkpoint from, None when none is named."""
        evaluation = self.evals.get(name)
        checkpoint = Path(evaluation.checkpoint or "") if evaluation else Path()
        return next((stage for stage, run in self.stages.items() if Path(run) in checkpoint.parents), None)

    def stage_runs(self) -> list[Path]:
        """The run dirs of its stages, in training order (`stages.stage_paths`): looked up once for its stages and
        job dir as they are (a table's cost lines ask thousands of times)."""
        return list(self._runs()[1])

    def resolved_stage_runs(self) -> list[Path]:
        """`stage_runs`, each resolved (symlinks followed): what tells two jobs' stages apart. Resolved once."""
        return list(self._runs()[2])

    def _runs(self) -> tuple:
        key = (tuple(self.stages.items()), str(self.job_dir))
        if self.runs_found is None or self.runs_found[0] != key:
            found = stages.stage_paths(self.stages, self.job_dir)
            self.runs_found = (key, found, [path.resolve() for path in found])
        return self.runs_found


def _evaluation(given: Evaluation | dict) -> Evaluation:
    return given if isinstance(given, Evaluation) else Evaluation.from_record(given)


def read_result(path: Path) -> JobResult:
    """A job's `result.json` (or the result it superseded) in today's form (`migrations.upgrade`), with its job dir;
    BadInput naming the file for one cut, altered or of a field of another type (`RECORD`)."""
    path = Path(path)
    record = upgrade(read_json(path), str(path))
    check_schema(record, RECORD, str(path))
    return JobResult.from_record(record, path.parent)


def write_result(path: Path, result: JobResult) -> JobResult:
    """Write a job's `result` (stamped with today's format) to `path` atomically; returns it."""
    write_json(path, stamp(result.record()))
    return result


def searchpath_overrides(overrides: list[str]) -> list[str]:
    """The `hydra.searchpath=...` overrides among a job's stage overrides: where a task of yours was found."""
    return [o for o in overrides if o.startswith("hydra.searchpath=")]


def every_stage_override(overrides: list[str]) -> str:
    """A sweep job's `overrides` (extra overrides for every stage) as one Hydra override: `overrides=['a=1','b=2']`."""
    return "overrides=[" + ",".join(repr(o) for o in overrides) + "]"


def recorded_stage_seconds(runs: dict[str, Path]) -> dict[str, float]:
    """Each stage's training core-seconds as its run records them now (`stages.stage_core_seconds`); a stage whose
    logs cannot be read is left out."""
    seconds = {}
    for name, path in runs.items():
        with contextlib.suppress(BadInput, OSError):
            seconds[name] = round(stages.stage_core_seconds(path), 3)  # a smoke iteration can take < 0.05 s
    return seconds
