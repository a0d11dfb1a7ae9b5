"""A table's cost from fixture runs with hand-made iteration times: shared stages counted once, resumed iterations
once, MuJoCo threads as cores, evaluation time recorded by the job or taken from file times."""

from __future__ import annotations

import datetime
import os
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mapush.config import compose_config
from mapush.logging.metrics import McapLogWriter
from mapush.report.cost import cost_line, measured_cost
from mapush.report.formats import Table, markdown, sidecar


def _stage(root: Path, name: str, threads: int, parts: list[dict[int, tuple[float, float]]]) -> Path:
    """A run dir with one metrics file per part: {iteration: (collection s, learning s)}."""
    run = root / name
    run.mkdir(parents=True)
    OmegaConf.save(compose_config([f"sim.nthread={threads}"]), run / "config.yaml")
    for part in parts:
        writer = McapLogWriter(str(run), progress=False)  # a second writer opens metrics.1.mcap, as a resume does
        for it, (collection, learning) in part.items():
            writer.add_scalar("Perf/collection_time", collection, it)
            writer.add_scalar("Perf/learning_time", learning, it)
            writer.add_scalar("Metrics/success_rate", 0.5, it)
            writer.end_iteration(it)
        writer.stop()
    (run / "policy.pt").write_bytes(b"")
    return run


@pytest.fixture
def two_jobs(tmp_path) -> list[dict]:
    # stage a, 1 thread: iteration 0 takes 1800 s; iteration 1 ran 1800 s, was cut, and ran again for 3600 s
    a = _stage(tmp_path, "a", 1, [{0: (1200.0, 600.0), 1: (1200.0, 600.0)}, {1: (2400.0, 1200.0)}])
    b = _stage(tmp_path, "b", 2, [{0: (2700.0, 900.0)}])  # 3600 s on 2 threads
    finished = datetime.datetime(2026, 1, 1, 12, 0, 0)
    stamp = finished.timestamp() - 1800.0  # the second job's evaluations: 1800 s after b's export
    os.utime(b / "policy.pt", (stamp, stamp))
    stages = {"mid": str(a), "high": str(b)}
    return [
        {"stages": stages, "eval_wall_s": 900.0, "finished": finished.isoformat()},
        {"stages": dict(stages), "finished": finished.isoformat()},  # reuses both stages
    ]


def test_cost_counts_shared_stages_and_repeated_iterations_once(two_jobs):
    cost = measured_cost(two_jobs, cores=2)
    # training: a 1800 + 3600 s x 1 thread = 1.5 core-h; b 3600 s x 2 threads = 2 core-h
    # evaluation: 900 s x 2 threads (b's) = 0.5 core-h recorded; 1800 s x 2 = 1 core-h from file times
    assert cost == {
        "stages": 2,
        "jobs": 2,
        "missing_runs": 0,
        "training_core_h": 3.5,
        "evaluation_core_h": 1.5,
        "evaluation_jobs_from_file_times": 1,
        "cores": 2,
        "machine_h": 2.5,
    }


def test_the_cost_line_stands_under_the_table_and_in_its_sidecar(two_jobs):
    cost = measured_cost(two_jobs, cores=2)
    table = Table("t", "T", ["Task"], ["S.R."], [], cost=cost)
    line = (
        "Cost, measured from the runs: training 3.5 core-hours over 2 distinct stages, evaluation 1.5 core-hours "
        "over 2 jobs, 1 of them from file times: 2.5 hours of this 2-core machine with every core busy"
    )
    assert line in markdown(table).splitlines()
    assert sidecar(table)["cost"] == cost
    assert cost_line(measured_cost([], cores=2)) == ""


def test_stage_runs_that_are_not_there_are_left_out_and_said(two_jobs, tmp_path):
    gone = {"stages": {"mid": str(tmp_path / "gone")}, "eval_wall_s": 10.0, "finished": "2026-01-01T12:00:00"}
    cost = measured_cost([*two_jobs, gone], cores=2)
    assert (cost["stages"], cost["jobs"], cost["missing_runs"], cost["machine_h"]) == (2, 2, 1, 2.5)
    assert "(1 stage run dirs not found, left out)" in cost_line(cost)
