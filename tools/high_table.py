"""The high level's result: learned high-level runs against the path-following reference, through the hierarchy.

Each run is evaluated with `mapush eval`'s code (its `eval.json`: OMPL path, learned high level, frozen mid level,
on the run's own config), and its config is also driven by the constant action (0, 0) that follows the planned
path (`tools/high_reference.py`), on the same seeds and maps. The table (Markdown and JSON) is generated from
those records; the paper's row comes from `mapush/report/paper.yaml`.

    python tools/high_table.py RUN_DIR [RUN_DIR ...] [--episodes N] [--seeds 0,1] [--out results/high_cuboid]
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np

from mapush.config import load_run_config, to_plain
from mapush.eval.rollout import evaluate
from mapush.report.tables import PAPER
from mapush.rundir import checkpoint_iteration

sys.path.insert(0, str(Path(__file__).parent))
from high_reference import constant_action

FOLLOW = [0.0, 0.0]
"""The action that puts every subgoal on the reference path."""


def evaluation_key(cfg: dict) -> str:
    """What the path-following reference depends on: the config less its seed and training-only settings."""
    level = copy.deepcopy(cfg["level"])
    level["path"].pop("plan_in_training")
    level["obstacles"] = {k: v for k, v in level["obstacles"].items() if not k.startswith("train_")}
    return json.dumps({k: cfg[k] for k in ("mid", "sim", "task", "lowlevel")} | {"level": level}, sort_keys=True)


def training_maps(cfg: dict) -> str:
    """The recipe's training maps, in words."""
    if cfg["level"]["path"]["plan_in_training"]:
        return "planned, as at evaluation"
    if cfg["level"]["obstacles"]["train_clear_path"]:
        return "curved paths, obstacles beside"
    return "curved paths, obstacles across (paper)"


def row(run: Path, episodes: int | None, seeds: list[int] | None, references: dict | None = None) -> dict:
    """One training seed: the learned high level's eval record, the reference's, and the training budget.

    `references` caches the path-following records of configs with the same `evaluation_key`."""
    learned = json.loads(evaluate(run, episodes, seeds).read_text())
    cfg = to_plain(load_run_config(run))
    references = {} if references is None else references
    key = evaluation_key(cfg) + json.dumps([learned["episodes"], learned["seeds"]])
    if key not in references:
        references[key] = constant_action(cfg, FOLLOW, learned["episodes"], learned["seeds"])
    reference = references[key]
    iterations = checkpoint_iteration(Path(learned["checkpoint"])) + 1
    decisions = iterations * cfg["num_envs"] * cfg["algo"]["num_steps_per_env"]
    return {
        "run": str(run),
        "seed": cfg["seed"],
        "training_maps": training_maps(cfg),
        "mid": cfg["mid"],
        "task": learned["task"],
        "num_agents": learned["num_agents"],
        "episodes": learned["episodes"],
        "seeds": learned["seeds"],
        "budget": {
            "num_envs": cfg["num_envs"],
            "iterations": iterations,
            "decisions": decisions,
            "env_steps": decisions * cfg["level"]["decision_steps"],
        },
        "learned": learned,
        "path_following": reference,
    }


def cell(records: list[dict], key: str, percent: bool) -> str:
    """Mean +- std of `key` over records; for one record, its own std over evaluation seeds."""
    scale, unit, digits = (100, " %", 1) if percent else (1, "", 3)
    values = np.array([r[key] for r in records]) * scale
    std = records[0][f"{key}_std"] * scale if len(values) == 1 else values.std()
    return f"{values.mean():.{digits}f} +- {std:.{digits}f}{unit}"


def markdown(rows: list[dict]) -> str:
    first = rows[0]
    paper = PAPER["main"]
    sr, ct = paper["success_rate"][first["task"]]["ours"], paper["completion_time"][first["task"]]["ours"]
    lines = [
        f"The whole hierarchy on the long-horizon {first['task']} task ({first['num_agents']} robots): OMPL path, "
        f"high level, frozen mid level, the run's low level; {first['episodes']} trials x evaluation seeds "
        f"{first['seeds']} per training seed. Per run: mean +- std over evaluation seeds; the mean row: over "
        f"training seeds. C.T. is normalized by the {first['learned']['timeout_s']:g} s timeout. Path following: the "
        f"constant action {tuple(FOLLOW)}, every subgoal on the planned path (tools/high_reference.py), on the same "
        "maps.",
        "",
        "| Training maps | Seed | Run | Budget | S.R. | C.T. | Path following S.R. | Path following C.T. |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for maps in dict.fromkeys(r["training_maps"] for r in rows):
        group = [r for r in rows if r["training_maps"] == maps]
        for r in group:
            b, le, pf = r["budget"], r["learned"], r["path_following"]
            lines.append(
                f"| {maps} | {r['seed']} | {Path(r['run']).name} | {b['iterations']} it x {b['num_envs']} envs "
                f"({b['decisions'] / 1e6:.2f}M decisions, {b['env_steps'] / 1e6:.1f}M env-steps) "
                f"| {cell([le], 'success_rate', True)} | {cell([le], 'completion_time', False)} "
                f"| {cell([pf], 'success_rate', True)} | {cell([pf], 'completion_time', False)} |"
            )
        if len(group) > 1:
            learned, follow = [r["learned"] for r in group], [r["path_following"] for r in group]
            lines.append(
                f"| {maps} | mean | | | {cell(learned, 'success_rate', True)} "
                f"| {cell(learned, 'completion_time', False)} "
                f"| {cell(follow, 'success_rate', True)} | {cell(follow, 'completion_time', False)} |"
            )
    lines.append(f"| paper (Ours) | | | | {sr[0]} +- {sr[1]} % | {ct[0]} +- {ct[1]} | | |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="high-level run dirs")
    parser.add_argument("--episodes", type=int, default=None, help="trials per seed (default: the run's eval.episodes)")
    parser.add_argument("--seeds", default=None, help="comma-separated (default: the run's eval.seeds)")
    parser.add_argument("--out", type=Path, default=Path("results/high_cuboid"), help="writes OUT.md and OUT.json")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")] if args.seeds else None
    references = {}
    rows = [row(run, args.episodes, seeds, references) for run in args.runs]
    table = markdown(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".md").write_text(table)
    args.out.with_suffix(".json").write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    print(table)


if __name__ == "__main__":
    main()
