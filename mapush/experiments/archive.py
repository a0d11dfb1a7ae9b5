"""Keep what the sweeps found when their runs are gone: `mapush archive` copies every job's `result.json` (and the
result it superseded) from a runs dir into a folder small enough to commit (`results/jobs/`, a few kB a job),
under the same relative path, with each stage's training core-seconds measured from its run while it is there.

A result holds everything a table needs (its evaluations, its learning curve, its evaluation time); the runs
behind it (checkpoints, logs) stay under `runs/`, which git ignores and a new machine does not have.
`mapush tables` reads the runs dir and the archive together; a job found in both counts once, the newer result.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from mapush.experiments.pipeline import RESULT, SUPERSEDED, recorded_stage_seconds
from mapush.experiments.stages import stage_paths

ARCHIVE = Path("results/jobs")
"""Where `mapush archive` writes and `mapush tables` also reads, relative to the working directory."""
ARCHIVED_FROM = "archived_from"
"""The key of an archived result that names the job dir it was copied from."""


def result_files(root: Path) -> list[Path]:
    """Every job's current and superseded result under `root`, in path order."""
    return sorted([*Path(root).glob(f"**/{RESULT}"), *Path(root).glob(f"**/{SUPERSEDED}")])


def archive_results(runs: Path, out: Path = ARCHIVE) -> tuple[list[Path], int]:
    """Copy every result under `runs` to `out` (same relative paths), each stage's core-seconds filled in from
    its run where the result lacks them. Returns the files written and the number already archived unchanged."""
    written, unchanged = [], 0
    out_resolved = Path(out).resolve()
    for path in result_files(runs):
        if out_resolved in path.resolve().parents:
            continue  # the archive inside the runs dir: not a job
        result = json.loads(path.read_text())
        job = {**result, "job_dir": str(path.parent)}
        runs_of = {name: run for name, run in zip(result.get("stages", {}), stage_paths(job), strict=True)}
        result["stage_core_s"] = {**recorded_stage_seconds(runs_of), **result.get("stage_core_s", {})}
        result.setdefault(ARCHIVED_FROM, str(path.parent))
        text = json.dumps(result, indent=2) + "\n"
        target = Path(out) / path.relative_to(runs)
        if target.is_file() and target.read_text() == text:
            unchanged += 1
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(".tmp")
        tmp.write_text(text)
        os.replace(tmp, target)
        written.append(target)
    return written, unchanged


def load_results(roots: list[Path]) -> list[dict]:
    """Every finished job's result under the `roots` (runs dirs or archives), each with its `job_dir`. A job found
    under more than one root (the same path below it) counts once: the result that finished last, else the
    first root's."""
    chosen: dict[Path, dict] = {}
    for root in roots:
        for path in sorted(Path(root).glob(f"**/{RESULT}")):
            result = json.loads(path.read_text())
            result["job_dir"] = str(path.parent)
            key = path.relative_to(root)
            if key not in chosen or str(result.get("finished", "")) > str(chosen[key].get("finished", "")):
                chosen[key] = result
    return [chosen[key] for key in sorted(chosen)]
