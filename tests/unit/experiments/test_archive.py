"""The results archive: jobs' results copied into a folder git keeps, with their stages' training time, so the
tables and their cost survive the runs (a new machine has no `runs/`)."""

from __future__ import annotations

import json
import shutil

import pytest
from stand_ins import stage_run

from mapush.experiments.archive import archive_results, load_results
from mapush.experiments.results import ARCHIVED_FROM, RESULT, SUPERSEDED
from mapush.report.cost import measured_cost
from mapush.report.main_table import main_table


def _job(sweep, name: str, seed: int, stage_runs: dict, success: float, finished: str) -> None:
    job = sweep / f"method=ours,seed={seed},task={name}"
    job.mkdir(parents=True)
    result = {
        "table": "main",
        "variant": "quick",
        "method": "ours",
        "task": name,
        "seed": seed,
        "stages": {k: str(v) for k, v in stage_runs.items()},
        "evals": {"main": {"success_rate": success, "completion_time": 0.5}},
        "eval_wall_s": 600.0,
        "threads": 1,
        "machine_cores": 2,
        "finished": finished,
    }
    (job / RESULT).write_text(json.dumps(result))


@pytest.fixture
def runs(tmp_path):
    """Two cuboid jobs sharing a mid-level stage (1800 s on 1 thread); each has its own high level (2 threads)."""
    root = tmp_path / "runs"
    store = root / "sweeps" / "stages"
    mid = stage_run(store / "aaaa" / "mid" / "cuboid", "run", 1, [{0: (1200.0, 600.0)}])
    high0 = stage_run(store / "bbbb" / "high" / "cuboid", "run", 2, [{0: (600.0, 300.0)}])
    high1 = stage_run(store / "cccc" / "high" / "cuboid", "run", 2, [{0: (900.0, 900.0)}])
    sweep = root / "sweeps" / "main_quick"
    _job(sweep, "cuboid", 0, {"mid": mid, "high": high0}, 0.8, "2026-01-01T10:00:00")
    _job(sweep, "cuboid", 1, {"mid": mid, "high": high1}, 0.6, "2026-01-01T11:00:00")
    return root


def test_the_archive_keeps_the_cells_and_the_cost_when_the_runs_are_gone(runs, tmp_path):
    before = load_results([runs])
    cost_before = measured_cost(before)
    # training: mid 1800 s x 1 + high 900 s x 2 + high 1800 s x 2 = 7200 core-s = 2 core-h; evaluation 2 x 600 s
    assert (cost_before["training_core_h"], cost_before["evaluation_core_h"]) == (2.0, pytest.approx(1 / 3, abs=0.01))

    archive = tmp_path / "results" / "jobs"
    written, unchanged = archive_results(runs, archive)
    assert (len(written), unchanged) == (2, 0)
    copy = json.loads((archive / "main_quick" / "method=ours,seed=0,task=cuboid" / RESULT).read_text())
    assert copy["stage_core_s"] == {"mid": 1800.0, "high": 1800.0}
    assert copy[ARCHIVED_FROM].endswith("method=ours,seed=0,task=cuboid")
    assert archive_results(runs, archive) == ([], 2)  # archiving again writes nothing new

    shutil.rmtree(runs)
    after = load_results([archive])
    assert [r.seed for r in after] == [0, 1]
    cost_after = measured_cost(after)
    assert cost_after["training_core_h"] == cost_before["training_core_h"]
    assert (cost_after["stages"], cost_after["stages_from_records"], cost_after["unreadable_stages"]) == (3, 3, 0)
    cell = next(c for _, cells in main_table(after, "quick").rows for c in cells if c.values)
    assert sorted(cell.values) == pytest.approx([60.0, 80.0])  # S.R. of Ours on the cuboid, both seeds
    assert all(str(archive) in source for source in cell.sources)


def test_a_job_in_the_runs_and_the_archive_counts_once_the_newer_result(runs, tmp_path):
    archive = tmp_path / "jobs"
    archive_results(runs, archive)
    job = runs / "sweeps" / "main_quick" / "method=ours,seed=1,task=cuboid"
    newer = json.loads((job / RESULT).read_text())
    (job / SUPERSEDED).write_text(json.dumps(newer))
    newer.update(finished="2026-01-02T09:00:00", supersedes=SUPERSEDED)
    newer["evals"]["main"]["success_rate"] = 0.9
    (job / RESULT).write_text(json.dumps(newer))

    results = load_results([runs, archive])
    assert [(r.seed, r.evals["main"].success_rate) for r in results] == [(0, 0.8), (1, 0.9)]
    assert str(runs) in results[1].job_dir  # the newer: still in the runs dir
    assert str(runs) in results[0].job_dir  # the same in both: the first root's

    archive_results(runs, archive)  # the rerun and the result it superseded both reach the archive
    shutil.rmtree(runs)
    results = load_results([archive])
    assert results[1].evals["main"].success_rate == 0.9
    assert measured_cost(results)["evaluated_again"] == 1


def test_a_job_running_again_is_archived_only_once_its_new_result_exists(runs, tmp_path):
    archive = tmp_path / "jobs"
    archive_results(runs, archive)
    job = runs / "sweeps" / "main_quick" / "method=ours,seed=1,task=cuboid"
    (job / RESULT).rename(job / SUPERSEDED)  # as `run_job` leaves a job it runs again, until it finishes
    written, unchanged = archive_results(runs, archive)
    assert (written, unchanged) == ([], 1)
    archived = archive / "main_quick" / job.name
    assert not (archived / SUPERSEDED).exists() and (archived / RESULT).is_file()
    assert measured_cost(load_results([archive]))["evaluated_again"] == 0


def test_archive_rejects_a_missing_runs_dir_and_writes_nothing(cli, tmp_path):
    proc = cli("archive", "--runs", tmp_path / "nowhere", "--out", tmp_path / "jobs")
    assert proc.returncode == 2 and "nowhere" in proc.stderr and "valid" in proc.stderr
    assert not (tmp_path / "jobs").exists()


def test_archived_jobs_keep_relative_stage_paths_and_adopted_stages_count_once(tmp_path, monkeypatch):
    # as a sweep writes them: stage paths relative to where it ran; the cylinder's seed-1 job names a stage that
    # `mapush stages rekey` adopted from the one seed 0 names (the same training, counted once)
    monkeypatch.chdir(tmp_path)
    store = tmp_path / "runs" / "sweeps" / "stages"
    old = stage_run(store / "00000000000000aa" / "mid" / "cylinder", "run", 1, [{0: (1800.0, 1800.0)}])
    (old.parents[2] / "stage.yaml").write_text("identity: 00000000000000aa\n")
    new = stage_run(store / "00000000000000bb" / "mid" / "cylinder", "run", 1, [{0: (1800.0, 1800.0)}])
    (new.parents[2] / "stage.yaml").write_text(
        "identity: 00000000000000bb\nadopted_from: {identity: 00000000000000aa}\n"
    )
    sweep = tmp_path / "runs" / "sweeps" / "main_quick"
    for seed, run in enumerate((old, new)):
        _job(sweep, "cylinder", seed, {"mid": run.relative_to(tmp_path)}, 0.5, f"2026-01-01T1{seed}:00:00")
    cost_before = measured_cost(load_results([tmp_path / "runs"]))
    assert (cost_before["stages"], cost_before["training_core_h"]) == (1, 1.0)

    archive_results(tmp_path / "runs", tmp_path / "jobs")
    assert (tmp_path / "jobs" / "stages" / "00000000000000aa" / "stage.yaml").is_file()  # the adoption chain
    # archived again from the sweep root instead of the runs dir: the same jobs, nothing new
    assert archive_results(tmp_path / "runs" / "sweeps", tmp_path / "jobs") == ([], 2)
    shutil.rmtree(tmp_path / "runs")
    cost_after = measured_cost(load_results([tmp_path / "jobs"]))
    assert (cost_after["stages"], cost_after["training_core_h"], cost_after["unreadable_stages"]) == (1, 1.0, 0)


def test_an_archive_inside_the_runs_dir_is_read_once(runs):
    inside = runs / "archive"
    archive_results(runs, inside)
    assert archive_results(runs, inside) == ([], 2)  # its own copies are no jobs to archive
    assert [r.seed for r in load_results([runs])] == [0, 1]
    assert [r.seed for r in load_results([runs, inside])] == [0, 1]
