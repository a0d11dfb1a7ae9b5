#!/usr/bin/env bash
# Make the archive's memo (results/jobs/jobs_checked.json) what a fresh clone finds: after a change to the code or
# configs that compose a job, a clone's `mapush tables` would compose every archived job again (a minute and more)
# until the memo is made anew. It runs `mapush tables` on a copy of results/jobs with this machine's runs/ hidden
# (a mount namespace: root only), then keeps one finding per job, the one a machine without the runs looks up.
# tests/repo/test_committed_tables.py fails while the committed memo lacks a job.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
copy=$(mktemp -d)
trap 'rm -rf "$copy"' EXIT
mkdir -p "$copy/results" && cp -r results/jobs "$copy/results/"
mkdir -p runs
(cd "$copy" && unshare -m bash -c "mount -t tmpfs none '$repo/runs' && '$repo/.venv/bin/mapush' tables \
    --runs results/jobs --out '$copy/out' > /dev/null")
.venv/bin/python - "$copy/results/jobs" <<'PY'
import sys
from pathlib import Path

from mapush.atomic import write_json
from mapush.experiments.archive import CHECKED, clone_memo, read_memo

kept, lacking = clone_memo(Path("results/jobs"), read_memo(Path(sys.argv[1]) / CHECKED))
assert not lacking, f"not found by the copy: {lacking[:3]}"
write_json(Path("results/jobs") / CHECKED, kept)
print(f"results/jobs/{CHECKED}: {len(kept)} jobs")
PY
