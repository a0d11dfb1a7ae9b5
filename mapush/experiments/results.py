"""A sweep job's record: `result.json` in its job dir, and the earlier result a rerun keeps beside it. Read and
written here only, so that every reader gets today's form (`migrations.upgrade`)."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

from mapush.atomic import write_json
from mapush.errors import BadInput
from mapush.experiments import stages
from mapush.migrations import stamp, upgrade

RESULT = "result.json"
"""A finished job's record, written by `run_job`, read by `read_result`."""


def read_result(path: Path) -> dict:
    """A job's `result.json` (or the result it superseded) as today's form (`migrations.upgrade`)."""
    return upgrade(json.loads(Path(path).read_text()), str(path))


SUPERSEDED = "result.superseded.json"
"""Where a job's earlier result goes when the experiment changed under it (`result_changes`)."""


def write_result(path: Path, result: dict) -> dict:
    """Write a job's `result` (stamped with today's format) to `path` atomically; returns what was written."""
    result = stamp(result)
    write_json(path, result)
    return result


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
