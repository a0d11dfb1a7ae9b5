"""The tables in results/ are what `mapush tables` makes of the archived results in results/jobs/ with this code:
none is typed in or left behind by older code."""

from __future__ import annotations

import shutil

import pytest
from paths import REPO

RESULTS = REPO / "results"
TEXT_SUFFIXES = (".md", ".csv", ".tex", ".json")


@pytest.mark.slow  # a minute and more after a code change (each archived job is checked again), seconds after
def test_the_committed_tables_are_regenerated_from_the_archive_as_they_are(cli, tmp_path):
    # as a fresh clone runs it, from its root: the archive at results/jobs, no runs/ (the cells name their sources
    # by the path given, and a stage run found under runs/ would be measured instead of its record)
    shutil.copytree(RESULTS / "jobs", tmp_path / "results" / "jobs")
    out = tmp_path / "out"  # a new dir: the memo of what was found of each job lies in the archive it speaks of
    proc = cli("tables", "--runs", "results/jobs", "--out", out, "--overwrite")
    assert proc.returncode == 0, proc.stderr
    made = sorted(p.name for p in out.iterdir() if p.suffix in TEXT_SUFFIXES)
    assert made, proc.stdout
    for name in made:
        assert (RESULTS / name).is_file(), f"results/{name} is made by mapush tables but not committed"
        assert (out / name).read_text() == (RESULTS / name).read_text(), f"results/{name} differs from what it makes"


def test_the_archive_memo_holds_every_archived_job_as_this_code_finds_it():
    # a stale memo (code or configs that compose a job changed since it was made) makes a fresh clone's
    # `mapush tables` compose all 90-odd jobs again: a minute and more instead of seconds
    from mapush.experiments.archive import CHECKED, memo_lacks

    stale, jobs = memo_lacks(RESULTS / "jobs")
    assert jobs
    assert not stale, (
        f"results/jobs/{CHECKED} lacks {len(stale)} of {jobs} jobs as this code finds them (e.g. {stale[:2]}): "
        "run tools/refresh_archive_memo.sh and commit the memo"
    )
