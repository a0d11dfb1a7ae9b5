"""Sim-to-sim check: mid-level policies trained on the `tracker` low level, evaluated on legged Go1s.

Each run is evaluated twice with `mapush eval`'s code on the same seeds and episodes: as trained
(`eval_sim2sim_tracker.json`) and with `lowlevel=go1` (`eval_sim2sim_go1.json`, the shipped locomotion policy
unless `lowlevel.policy=...` is given). The table (Markdown and JSON) is generated from those two files.

    python tools/sim2sim.py RUN_DIR [RUN_DIR ...] [--episodes N] [--seeds 0,1] [--out results/sim2sim]
                            [lowlevel.policy=RUN/policy.pt]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mapush.eval.rollout import evaluate
from mapush.lowlevel.go1 import PRETRAINED_RUN


def check(run: Path, episodes: int, seeds: list[int], go1_overrides: list[str]) -> dict:
    """Both evaluations of one mid-level run; the row of the table."""
    tracker = json.loads(evaluate(run, episodes, seeds, [], name="sim2sim_tracker").read_text())
    go1 = json.loads(evaluate(run, episodes, seeds, ["lowlevel=go1", *go1_overrides], name="sim2sim_go1").read_text())
    return {
        "run": str(run),
        "task": tracker["task"],
        "num_agents": tracker["num_agents"],
        "episodes": tracker["episodes"],
        "seeds": tracker["seeds"],
        "tracker": {k: tracker[k] for k in ("success_rate", "success_rate_std", "completion_time")},
        "go1": {k: go1[k] for k in ("success_rate", "success_rate_std", "completion_time")},
        "go1_exception_rate": sum(s["exception_rate"] for s in go1["per_seed"]) / len(go1["per_seed"]),
        "drop": tracker["success_rate"] - go1["success_rate"],
    }


def markdown(rows: list[dict], episodes: int, seeds: list[int], policy: str) -> str:
    lines = [
        f"Mid-level policies trained on the tracker, evaluated on it and on legged Go1s ({policy}); "
        f"{episodes} trials x seeds {seeds}. S.R. is mean +- std over evaluation seeds.",
        "",
        "| Run | Task | Robots | S.R. tracker | S.R. Go1 | Drop | C.T. tracker | C.T. Go1 | Go1 exceptions |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        t, g = r["tracker"], r["go1"]
        lines.append(
            f"| {Path(r['run']).name} | {r['task']} | {r['num_agents']} "
            f"| {100 * t['success_rate']:.1f} +- {100 * t['success_rate_std']:.1f} % "
            f"| {100 * g['success_rate']:.1f} +- {100 * g['success_rate_std']:.1f} % "
            f"| {100 * r['drop']:.1f} pp | {t['completion_time']:.3f} | {g['completion_time']:.3f} "
            f"| {100 * r['go1_exception_rate']:.1f} % |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="mid-level run dirs trained with lowlevel=tracker")
    parser.add_argument("--episodes", type=int, default=None, help="trials per seed (default: the run's eval.episodes)")
    parser.add_argument("--seeds", default=None, help="comma-separated (default: the run's eval.seeds)")
    parser.add_argument("--out", type=Path, default=Path("results/sim2sim"), help="writes OUT.md and OUT.json")
    args, overrides = parser.parse_known_args()
    seeds = [int(s) for s in args.seeds.split(",")] if args.seeds else None
    rows = [check(run, args.episodes, seeds, overrides) for run in args.runs]
    episodes, seeds = rows[0]["episodes"], rows[0]["seeds"]
    policy = next((o.split("=", 1)[1] for o in overrides if o.startswith("lowlevel.policy=")), None)
    if policy is None:
        source = json.loads((PRETRAINED_RUN / "meta.json").read_text())["shipped_from"]
        policy = f"the shipped policy: run {source['run']}, {source['checkpoint']}"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    table = markdown(rows, episodes, seeds, policy)
    args.out.with_suffix(".md").write_text(table)
    record = {"episodes": episodes, "seeds": seeds, "policy": policy, "rows": rows}
    args.out.with_suffix(".json").write_text(json.dumps(record, indent=2) + "\n")
    print(table)


if __name__ == "__main__":
    main()
