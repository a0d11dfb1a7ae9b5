#!/usr/bin/env bash
# The shipped hierarchies (Ours) and their mid levels under the original's rules and mapush's, one rule at a time,
# on today's calibrated tracker (lowlevel=tracker): evaluation only, nothing is trained. Each eval.json is copied
# to results/rules/<object>_<rung>.json; docs/notes/2026-12-06-rules-original-and-strict.md reads them.
#   bash tools/rules_ladder.sh [EPISODES]     (default 50 episodes, seed 0; 4x at the mid level; rerunning skips finished rungs)
# The rung high_original_friction evaluates at the original high-level env's friction: object U[0.05, 4.5] against a
# floor of 1.0, averaged as PhysX does, U[0.525, 2.75].
set -euo pipefail
cd "$(dirname "$0")/.."
episodes=${1:-50}
out=results/rules
mkdir -p "$out"
MAPUSH=${MAPUSH:-.venv/bin/mapush}
OLD_FALL='++lowlevel.fall={load_n:58.5,width_n:1.42,window_s:4,filter_s:0.2}'  # the tracker of 2026-12-04
rung() {  # rung OBJECT LEVEL NAME OVERRIDES...
  local object=$1 level=$2 name=$3
  shift 3
  [ -f "$out/${object}_${name}.json" ] && return 0
  local target="shipped:${object}"
  [ "$level" = mid ] && target="mapush/policies/${object}/mid"
  local n=$episodes
  [ "$level" = mid ] && n=$((episodes * 4))
  "$MAPUSH" eval "$target" --episodes "$n" --seeds 0 --name "rules_${name}" lowlevel=tracker "$@" \
    >/dev/null
  cp "runs/shipped/policies/${object}/${level}/eval_rules_${name}.json" "$out/${object}_${name}.json"
}
for object in cylinder cuboid tblock; do  # the rungs, from the original's setup toward mapush's
  rung "$object" high high_original_friction rules=original "task.object.friction=[0.525,2.75]"
  rung "$object" high high_original rules=original
  rung "$object" high high_fall_ends rules=original "level.terminal_exceptions=[diverged,robot_tilt]"
  rung "$object" high high_strict rules=strict
  rung "$object" high high_strict_old_tracker rules=strict lowlevel.fall=null "$OLD_FALL"
  rung "$object" mid mid_original rules=original
  rung "$object" mid mid_strict rules=strict
done
