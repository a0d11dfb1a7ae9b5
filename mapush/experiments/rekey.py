"""`mapush stages rekey`: carry a sweep's finished stages over to a newer commit whose configs name them differently
but behave alike.

A stage's identity hashes its composed config, so a commit that only reorganises the config (the same numbers
under new keys, as f56d309 did when observations and exceptions became config terms) gives every stage a new
identity, and a sweep at that commit would train them all again. Run from the newer checkout, `rekey`:

1. fingerprints every level on the mapush of the old checkout and on this one (`mapush stages fingerprint`: this
   commit's `fingerprint.py`, run with each checkout on PYTHONPATH, so that both are hashed alike) and stops unless
   every hash agrees, that is unless both commits compute bitwise-equal observations, rewards and episode ends;
2. plans the sweep at both commits (`dry_run`) and pairs their stages by job and stage name;
3. for each old stage with a run (finished, or cut after a checkpoint) whose new identity has none yet, makes
   `stages/<new>/`: a `stage.yaml` with the new identity, the config this commit composes and `adopted_from`
   (old identity, commit, fingerprints), and a copy of the old run dir whose weights are hard links (`find_runs`
   does not follow symbolic links, and a resumed run appends to its logs, so those are copied). The old stage
   stays as it was; a sweep at this commit reuses the finished ones and resumes the cut ones.

Run it before a change that alters behaviour: the pairing trusts that only the config's form changed.

    mapush stages rekey OLD_CHECKOUT MID_RUN experiment=main [more sweep overrides]
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from mapush.children import dies_with_parent
from mapush.experiments import stages
from mapush.experiments.sweep import dry_run
from mapush.experiments.sweep_axes import planned_jobs, sweep_overrides
from mapush.rundir import find_runs

HERE = Path(__file__).resolve().parents[2]
"""The checkout (or site-packages) this mapush runs from: the newer commit."""
PLAN = (
    "import json, sys; from mapush.experiments.sweep import dry_run; print('ROWS', json.dumps(dry_run(sys.argv[1:])))"
)
FINGERPRINT = Path(__file__).with_name("fingerprint.py")
RUN_FINGERPRINT = "import json, runpy, sys; print(json.dumps(runpy.run_path(sys.argv[1])['fingerprint'](sys.argv[2])))"


class CheckoutFailed(Exception):
    """A command at a checkout exited nonzero; the message holds the end of its stderr."""


def at_checkout(checkout: Path, args: list[str]) -> str:
    """Run python with `args` on the mapush of `checkout`; its stdout."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    done = subprocess.run(
        [sys.executable, *args], cwd=checkout, env=env, capture_output=True, text=True, preexec_fn=dies_with_parent()
    )
    if done.returncode:
        raise CheckoutFailed(f"{checkout}: {' '.join(args)} failed:\n{done.stderr[-2000:]}")
    return done.stdout


def fingerprint_at(checkout: Path, mid_run: str) -> dict[str, str]:
    """The fingerprints of the mapush of `checkout`, hashed by this commit's `fingerprint.py` (an older checkout's
    own may hash other rollouts, or be missing)."""
    out = at_checkout(checkout, ["-c", RUN_FINGERPRINT, str(FINGERPRINT), mid_run])
    return json.loads(out.splitlines()[-1])


def commit_of(checkout: Path) -> str:
    return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=checkout, capture_output=True, text=True,
                          check=True).stdout.strip()  # fmt: skip


def rekey(old: Path, mid_run: str, overrides: list[str]) -> int:
    """Adopt the stages `old` trained for the sweep of `overrides` under this commit's identities; 1 (nothing
    adopted) when the fingerprints differ, else 0."""
    with ThreadPoolExecutor(2) as pool:  # the two checkouts hashed at once, each in its own process
        old_print, new_print = pool.map(lambda path: fingerprint_at(path, mid_run), (old, HERE))
    prints = {"old": old_print, "new": new_print}
    if prints["old"] != prints["new"]:
        print(f"fingerprints differ, nothing adopted:\n  old {prints['old']}\n  new {prints['new']}")
        return 1
    old_commit = commit_of(old)
    old_rows = json.loads(at_checkout(old, ["-c", PLAN, *overrides]).split("ROWS ", 1)[1])
    old_ids = {(r["job"], r["stage"]): r["identity"] for r in old_rows}
    new_rows = dry_run(overrides)
    planned = {}
    for job in planned_jobs(sweep_overrides(overrides)):
        for stage in job.stages:
            planned[stage.identity] = (stage, Path(job.cfg.sweep_root))
    adopted = 0
    for row in new_rows:
        key = (row["job"], row["stage"])
        if key not in old_ids or row["action"] != "train":
            continue
        stage, root = planned[row["identity"]]
        source = stages.stage_dir(root, old_ids[key])
        done = stages.trained_iterations(source)
        if done == 0:
            continue
        target = stages.stage_dir(root, row["identity"])
        for run_dir in find_runs(source):
            stages.copy_run(run_dir, target / run_dir.relative_to(source))
        cfg = stages.compose_stage(stage.overrides, lambda c, n=stage.iterations: n)
        adopted_from = {"identity": old_ids[key], "commit": old_commit, "fingerprints": prints["new"]}
        stages.write_identity(target, cfg, row["identity"], adopted_from=adopted_from)
        trained = "finished" if done is None else f"{done}/{stage.iterations} iterations"
        print(f"adopted {row['job']} {row['stage']} ({trained}): "
              f"{old_ids[key]} -> {row['identity']}")  # fmt: skip
        adopted += 1
    print(f"{adopted} stages adopted from {old_commit} (fingerprints equal: {prints['new']})")
    return 0
