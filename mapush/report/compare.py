"""`mapush compare`: runs evaluated as trained and with overrides, on the same seeds and episodes, as one table.

The sim-to-sim check is its main use: mid levels trained on the `tracker` low level, evaluated on it and on
legged Go1s (`lowlevel=go1`, the shipped locomotion policy unless `lowlevel.policy=...` is given). Each run gets
`eval_as_trained.json` and `eval_<overrides>.json` (`mapush eval`'s own code); the table (Markdown and JSON) is
generated from those two files.
"""

from __future__ import annotations

import json
from pathlib import Path

from mapush.atomic import write_json, write_text
from mapush.config import overrides_name
from mapush.errors import BadInput
from mapush.eval.rollout import evaluate

AS_TRAINED = "as_trained"
CELLS = ("success_rate", "success_rate_std", "completion_time")


def compare_run(run: Path, episodes: int | None, seeds: list[int] | None, overrides: list[str]) -> dict:
    """Both evaluations of one run; the row of the table."""
    if not overrides:
        raise BadInput("mapush compare needs overrides to compare with, e.g. lowlevel=go1; valid: key=value ...")
    base = json.loads(evaluate(run, episodes, seeds, [], name=AS_TRAINED).read_text())
    other = json.loads(evaluate(run, episodes, seeds, overrides, name=overrides_name(overrides)).read_text())
    return {
        "run": str(run),
        "task": base["task"],
        "num_agents": base["num_agents"],
        "episodes": base["episodes"],
        "seeds": base["seeds"],
        "as_trained": {k: base[k] for k in CELLS},
        "with_overrides": {k: other[k] for k in CELLS},
        "exception_rate": sum(s["exception_rate"] for s in other["per_seed"]) / len(other["per_seed"]),
        "drop": base["success_rate"] - other["success_rate"],
    }


def markdown(rows: list[dict], overrides: list[str]) -> str:
    """The table of `compare_run` rows; S.R. is mean +- std over evaluation seeds."""
    changed = " ".join(overrides)
    lines = [
        f"Runs evaluated as trained and with `{changed}`; {rows[0]['episodes']} trials x seeds {rows[0]['seeds']}. "
        "S.R. is mean +- std over evaluation seeds.",
        "",
        f"| Run | Task | Robots | S.R. as trained | S.R. `{changed}` | Drop | C.T. as trained | C.T. `{changed}` "
        "| Exceptions |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        a, b = r["as_trained"], r["with_overrides"]
        lines.append(
            f"| {Path(r['run']).name} | {r['task']} | {r['num_agents']} "
            f"| {100 * a['success_rate']:.1f} +- {100 * a['success_rate_std']:.1f} % "
            f"| {100 * b['success_rate']:.1f} +- {100 * b['success_rate_std']:.1f} % "
            f"| {100 * r['drop']:.1f} pp | {a['completion_time']:.3f} | {b['completion_time']:.3f} "
            f"| {100 * r['exception_rate']:.1f} % |"
        )
    return "\n".join(lines) + "\n"


def write_comparison(rows: list[dict], overrides: list[str], out: Path) -> str:
    """`out`.md and `out`.json from the rows; returns the Markdown."""
    out.parent.mkdir(parents=True, exist_ok=True)
    table = markdown(rows, overrides)
    write_text(out.with_suffix(".md"), table)
    write_json(out.with_suffix(".json"), {"overrides": overrides, "rows": rows})
    return table
