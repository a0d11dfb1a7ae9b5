"""Draw results/rules/ladder.md from the evaluations `tools/rules_ladder.sh` copied to results/rules/.

One row per object, one column per rung, from the original's setup toward mapush's; each cell the S.R. of the
shipped policy and, under it, the share of episodes in which a robot fell. A rung not yet evaluated is "-".

    .venv/bin/python tools/rules_ladder_table.py
"""

from __future__ import annotations

import json
from pathlib import Path

RULES = Path(__file__).resolve().parent.parent / "results" / "rules"
OBJECTS = ("cuboid", "tblock", "cylinder")
RUNGS = {
    "high_original_friction": "0: original rules, the original high-level env's friction",
    "high_original": "1: original rules (mid env's friction)",
    "high_fall_ends": "2: + a fall ends the episode",
    "high_strict": "3: mapush's rules (+ a tilted object or a failed plan ends it)",
    "high_strict_old_tracker": "4: + the tracker's fall model of 2026-12-04",
    "mid_original": "mid level alone, original rules",
    "mid_strict": "mid level alone, mapush's rules (+ touching robots end a push)",
}


def cell(path: Path) -> str:
    if not path.is_file():
        return "-"
    record = json.loads(path.read_text())
    falls = record.get("events", {}).get("falls", {}).get("episode_share")
    fell = f", falls in {100 * falls:.0f} %" if falls is not None else ""
    return f"{100 * record['success_rate']:.1f} % ({record['episodes']} ep.{fell})"


def main() -> None:
    lines = [
        "# The shipped Ours hierarchies, rule by rule",
        "",
        "Made by `tools/rules_ladder_table.py` from the evaluations in this folder (`tools/rules_ladder.sh`: "
        "`mapush eval` of the shipped policies on today's tracker, seed 0; nothing trained). Each cell: S.R., "
        "episodes, the share of episodes in which a robot fell.",
        "",
        "| rung | " + " | ".join(OBJECTS) + " |",
        "|---|" + "---|" * len(OBJECTS),
    ]
    for rung, title in RUNGS.items():
        lines.append(f"| {title} | " + " | ".join(cell(RULES / f"{o}_{rung}.json") for o in OBJECTS) + " |")
    (RULES / "ladder.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
