"""A table's cost from fixture runs with hand-made iteration times: shared stages counted once, resumed iterations
once, MuJoCo threads as cores, evaluation time recorded by the job or taken from file times."""

from __future__ import annotations

import datetime
import os

import pytest
from stand_ins import as_results, stage_run

from mapush.experiments.stages import stage_core_seconds
from mapush.logging.mcap_files import CPU_TAG, training_scalars
from mapush.report.cost import cost_after, cost_by, cost_line, measured_cost
from mapush.report.formats import Table, markdown, sidecar


@pytest.fixture
def two_jobs(tmp_path) -> list[dict]:
    # stage a, 1 thread: iteration 0 takes 1800 s; iteration 1 ran 1800 s, was cut, and ran again for 3600 s
    a = stage_run(tmp_path, "a", 1, [{0: (1200.0, 600.0), 1: (1200.0, 600.0)}, {1: (2400.0, 1200.0)}])
    b = stage_run(tmp_path, "b", 2, [{0: (2700.0, 900.0)}])  # 3600 s on 2 threads
    finished = datetime.datetime(2026, 1, 1, 12, 0, 0)
    stamp = finished.timestamp() - 1800.0  # the first job's evaluations: 1800 s after b's export
    os.utime(b / "policy.pt", (stamp, stamp))
    stages = {"mid": str(a), "high": str(b)}
    later = (finished + datetime.timedelta(hours=1)).isoformat()
    return [
        {"stages": stages, "finished": finished.isoformat()},  # before eval_wall_s: file times
        {"stages": dict(stages), "eval_wall_s": 900.0, "threads": 2, "finished": later},  # reuses both stages
    ]


def test_an_iteration_that_stood_still_counts_as_a_median_one(tmp_path):
    # 30 iterations of 3 s on 1 thread; iteration 12 includes 26 minutes with the process stopped (kill -STOP)
    times = {it: (1.0, 2.0) for it in range(30)}
    times[12] = (1.0, 1560.0 + 2.0)
    assert stage_core_seconds(stage_run(tmp_path, "paused", 1, [times])) == pytest.approx(90.0)
    # a slow iteration below the factor is work, and counts whole: 29 x 3 s + 50 s
    times[12] = (1.0, 49.0)
    assert stage_core_seconds(stage_run(tmp_path, "slow", 2, [times])) == pytest.approx(2 * (29 * 3.0 + 50.0))


def test_a_run_resumed_with_other_threads_counts_each_iteration_at_its_own(tmp_path):
    # cut after iterations 0 and 1 on 2 threads, before runs recorded their threads (the config says 2); resumed
    # with 1 thread, which repeats iteration 1: 3 s x 2 threads, then 2 x 3 s x 1 thread
    parts = [{0: (1.0, 2.0), 1: (1.0, 2.0)}, {1: (1.0, 2.0), 2: (1.0, 2.0)}]
    assert stage_core_seconds(stage_run(tmp_path, "moved", 2, parts, recorded=[0, 1])) == pytest.approx(12.0)
    # without the record every iteration counts at the config's threads
    assert stage_core_seconds(stage_run(tmp_path, "unrecorded", 2, parts)) == pytest.approx(18.0)


def test_an_iteration_that_recorded_its_cpu_time_counts_that_not_its_wall_time(tmp_path):
    # two jobs on one core each and a third process beside them: 3 s of wall, 2 s of CPU, on 1 thread; the second
    # part (resumed after the record existed) is counted in CPU seconds, the first (before it) in wall time
    parts = [{0: (1.0, 2.0), 1: (1.0, 2.0)}, {2: (1.0, 2.0, 2.0), 3: (1.0, 2.0, 2.0)}]
    assert stage_core_seconds(stage_run(tmp_path, "crowded", 1, parts, recorded=[1, 1])) == pytest.approx(10.0)
    # CPU seconds hold however long the process stood still: no median stands in for them
    paused = {it: (1.0, 2.0, 3.0) for it in range(30)}
    paused[12] = (1.0, 1562.0, 3.0)
    assert stage_core_seconds(stage_run(tmp_path, "paused", 1, [paused])) == pytest.approx(90.0)


def test_a_training_records_each_iterations_cpu_seconds(smoke_run):
    cpu = training_scalars(smoke_run, prefix="Perf/")[CPU_TAG]
    assert sorted(cpu) == [0, 1] and all(0.0 < seconds < 600.0 for seconds in cpu.values())


def test_cost_counts_shared_stages_and_repeated_iterations_once(two_jobs):
    cost = measured_cost(as_results(two_jobs), cores=2)
    # training: a 1800 + 3600 s x 1 thread = 1.5 core-h; b 3600 s x 2 threads = 2 core-h
    # evaluation: 1800 s x 2 threads (b's) = 1 core-h from file times; 900 s x 2 recorded threads = 0.5 core-h
    assert cost == {
        "stages": 2,
        "unreadable_stages": 0,
        "stages_from_records": 0,
        "jobs": 2,
        "evaluated_again": 0,
        "jobs_without_evaluation_time": 0,
        "training_core_h": 3.5,
        "evaluation_core_h": 1.5,
        "evaluation_jobs_from_file_times": 1,
        "jobs_taken": 0,
        "cores": 2,
        "machine_h": 2.5,
        "superseded": 0,
        "superseded_machine_h": 0.0,
        "other_machines": {},
        "other_machines_core_h": 0.0,
    }


def test_only_the_first_job_to_evaluate_a_stage_takes_its_time_from_file_times(two_jobs):
    reuser = {k: v for k, v in two_jobs[1].items() if k not in ("eval_wall_s", "threads")}  # an old reusing job
    cost = measured_cost(as_results([two_jobs[0], reuser]), cores=2)
    assert (cost["jobs"], cost["jobs_without_evaluation_time"], cost["evaluation_core_h"]) == (1, 1, 1.0)


def test_the_cost_line_stands_under_the_table_and_in_its_sidecar(two_jobs):
    cost = measured_cost(as_results(two_jobs), cores=2)
    table = Table("t", "T", ["Task"], ["S.R."], [], cost=cost)
    line = (
        "Cost, measured from the runs (each stage once, each of its iterations once): training 3.5 core-hours over "
        "2 distinct stages, evaluation 1.5 core-hours over 2 jobs (1 of the jobs' evaluation times from file "
        "times): 2.5 hours of a 2-core machine with every core busy"
    )
    assert line in markdown(table).splitlines()
    assert sidecar(table)["cost"] == cost
    assert cost_line(measured_cost([], cores=2)) == ""


def test_jobs_that_ran_on_a_machine_of_other_cores_are_counted_and_said_apart(two_jobs, tmp_path):
    c = stage_run(tmp_path, "c", 1, [{0: (3000.0, 600.0)}])  # 1 core-h, trained on a lent 16-core machine
    lent = {"stages": {"high": str(c)}, "eval_wall_s": 1800.0, "threads": 1, "machine_cores": 16}
    here = [{**r, "machine_cores": 2} for r in two_jobs]  # 3.5 + 1.5 core-h, as above
    cost = measured_cost(as_results([*here, lent, dict(lent)]), cores=2)
    # the two lent jobs share stage c: 1 core-h of training and 2 x 0.5 core-h of evaluation
    assert (cost["cores"], cost["other_machines"], cost["other_machines_core_h"]) == (2, {16: 2}, 2.0)
    assert cost["machine_h"] == 3.5  # (3.5 + 1.5 + 2.0) core-h / 2 cores
    assert "jobs run elsewhere: 2 on a 16-core machine; their 2.0 core-hours are counted as measured" in cost_line(cost)
    assert "elsewhere" not in cost_line(measured_cost(as_results(here)))  # the machine the jobs record: 2 cores


def test_each_method_is_charged_what_it_added_and_the_parts_add_up_to_the_whole(two_jobs, tmp_path):
    ours = [{**r, "method_label": "Ours"} for r in two_jobs]  # 3.5 + 1.5 core-h: 2.5 h of 2 cores, as above
    c = stage_run(tmp_path, "c", 1, [{0: (3000.0, 600.0)}])  # 1 core-h
    # a baseline reusing Ours' stage a (charged to Ours, the first to use it), training c, evaluating 1 core-h
    baseline = {"stages": {"mid": two_jobs[0]["stages"]["mid"], "high": str(c)}, "method_label": "SA"}
    baseline |= {"eval_wall_s": 3600.0, "threads": 1, "finished": "2026-01-01T14:00:00"}
    assert cost_by(as_results([*ours, baseline]), "method_label", cores=2) == {"Ours": 2.5, "SA": 1.0}
    cost = measured_cost(as_results([*ours, baseline]), cores=2) | {"by_method": {"Ours": 2.5, "SA": 1.0}}
    assert cost["machine_h"] == 3.5
    assert cost_line(cost).endswith(
        "3.5 hours of a 2-core machine with every core busy; by method, in hours of that machine: Ours 2.5, SA 1.0"
    )
    assert "by method" not in cost_line(cost | {"by_method": {"Ours": 3.5}})  # one method: nothing to split


def test_a_table_that_shares_stages_with_another_is_charged_apart_what_it_adds_after_it(two_jobs, tmp_path):
    main = [{**r, "table": "main"} for r in two_jobs]  # stages a and b: 2.5 h of 2 cores, as above
    c = stage_run(tmp_path, "c", 1, [{0: (3000.0, 600.0)}])  # 1 core-h
    # the scalability study: one job evaluates a again (1 core-h), one trains c and evaluates it (1 core-h)
    scale = [
        {"stages": {"mid": two_jobs[0]["stages"]["mid"]}, "eval_wall_s": 3600.0, "threads": 1, "table": "scale"},
        {"stages": {"mid": str(c)}, "eval_wall_s": 1800.0, "threads": 2, "table": "scale"},
    ]
    # alone it costs a (1.5 core-h) + c (1) + its evaluations (2): 2.25 h of 2 cores; after the main table, a is
    # trained: (1 + 2) core-h = 1.5 h
    assert measured_cost(as_results(scale), cores=2)["machine_h"] == 2.25
    assert cost_after(as_results(scale), as_results(main), cores=2) == {
        "tables": ["main"],
        "shared_stages": 1,
        "machine_h": 1.5,
    }
    assert cost_after(as_results(scale[1:]), as_results(main), cores=2) is None  # no stage shared: nothing to say apart
    cost = measured_cost(as_results(scale), cores=2) | {
        "after": cost_after(as_results(scale), as_results(main), cores=2)
    }
    assert cost_line(cost).endswith(
        "2.2 hours of a 2-core machine with every core busy; run after the main table's jobs (1 stages shared), "
        "it adds 1.5 hours"
    )


def test_a_job_taken_from_another_tables_job_adds_no_evaluation_and_says_whose_it_is(two_jobs):
    main = [{**r, "table": "main"} for r in two_jobs]  # 2.5 h of 2 cores, as above
    taken = {"stages": dict(two_jobs[1]["stages"]), "eval_wall_s": 0.0, "threads": 2, "table": "scale"}
    taken["taken_from"] = "results/jobs/main_quick/method=sa,seed=0,task=cylinder"
    cost = measured_cost(as_results([taken]), cores=2)
    assert (cost["training_core_h"], cost["evaluation_core_h"], cost["jobs_taken"]) == (3.5, 0.0, 1)
    assert "1 jobs' results taken from other tables' jobs, whose evaluation they count" in cost_line(cost)
    assert cost_after(as_results([taken]), as_results(main), cores=2)["machine_h"] == 0.0  # nothing added


def test_stage_runs_are_found_under_the_sweep_root_or_counted_as_unreadable(two_jobs, tmp_path):
    # a job stored relative to the dir its sweep ran in: sweep root <root>, stages under <root>/stages/
    root = tmp_path / "elsewhere" / "sweeps"
    stage = root / "stages" / "abc" / "mid" / "run"
    stage.parent.mkdir(parents=True)
    os.rename(two_jobs[0]["stages"]["mid"], stage)
    relative = {"stages": {"mid": "runs/sweeps/stages/abc/mid/run"}, "eval_wall_s": 36.0, "threads": 1,
                "job_dir": str(root / "main_quick" / "job"), "finished": "2026-01-01T12:00:00"}  # fmt: skip
    gone = {"stages": {"mid": str(tmp_path / "gone")}, "eval_wall_s": 10.0, "finished": "2026-01-01T12:00:00"}
    cost = measured_cost(as_results([relative, gone]), cores=1)
    # the relative stage is a's 5400 s on 1 thread; its job's 36 s; the missing stage and its job are left out
    assert (cost["stages"], cost["unreadable_stages"], cost["jobs"], cost["jobs_without_evaluation_time"]) == (
        1, 1, 1, 1)  # fmt: skip
    assert (cost["training_core_h"], cost["evaluation_core_h"]) == (1.5, 0.01)
    assert "1 stage runs not found or unreadable, left out" in cost_line(cost)


def test_a_job_that_ran_again_counts_the_evaluations_of_its_earlier_result_too(two_jobs, tmp_path):
    import json

    job = tmp_path / "job"
    job.mkdir()
    (job / "result.superseded.json").write_text(json.dumps({**two_jobs[1], "eval_wall_s": 300.0}))
    again = {**two_jobs[1], "eval_wall_s": 120.0, "supersedes": "result.superseded.json", "job_dir": str(job)}
    cost = measured_cost(as_results([again]), cores=2)
    # the same two stages; evaluation (300 + 120 s) x 2 threads = 0.23 core-h over the job and its earlier result
    assert (cost["stages"], cost["jobs"], cost["evaluated_again"], cost["evaluation_core_h"]) == (2, 1, 1, 0.23)
    assert "1 jobs evaluated again after their experiment changed: both counted" in cost_line(cost)
    assert (
        measured_cost(as_results([{k: v for k, v in again.items() if k != "supersedes"}]), cores=2)["evaluation_core_h"]
        == 0.07
    )


def test_an_earlier_result_of_other_stages_is_given_apart_not_counted(two_jobs, tmp_path):
    import json

    # the job ran again after its high level's budget changed: its earlier result was made of another high stage
    # (old, 7200 s on 1 thread) and evaluated for 600 s on 2 threads
    old = stage_run(tmp_path, "old_high", 1, [{0: (3600.0, 3600.0)}])
    job = tmp_path / "job"
    job.mkdir()
    earlier = {**two_jobs[1], "stages": {**two_jobs[1]["stages"], "high": str(old)}, "eval_wall_s": 600.0}
    (job / "result.superseded.json").write_text(json.dumps(earlier))
    again = {**two_jobs[1], "supersedes": "result.superseded.json", "job_dir": str(job)}
    cost = measured_cost(as_results([again]), cores=2)
    # what stands: a (5400 s) and b (7200 core-s) trained, 900 s x 2 threads evaluated = 14400 core-s = 2.0 h of 2
    # cores; apart: the old high level 7200 core-s and its evaluation 1200 core-s = 8400 core-s = 1.17 h
    assert (cost["stages"], cost["jobs"], cost["machine_h"]) == (2, 1, 2.0)
    assert (cost["evaluated_again"], cost["superseded"], cost["superseded_machine_h"]) == (0, 1, 1.17)
    assert "not counted: 1.2 hours more on 1 earlier results" in cost_line(cost)


def test_a_stage_adopted_into_a_new_identity_is_trained_once(tmp_path):
    # `mapush stages rekey` copies a stage's run under a new identity; results naming either count its training once
    store = tmp_path / "sweeps" / "stages"
    old = stage_run(store / "00000000000000aa" / "mid" / "cuboid", "run", 1, [{0: (1800.0, 1800.0)}])
    (old.parents[2] / "stage.yaml").write_text("identity: 00000000000000aa\n")
    new = stage_run(store / "00000000000000bb" / "mid" / "cuboid", "run", 1, [{0: (1800.0, 1800.0)}])
    (new.parents[2] / "stage.yaml").write_text(
        "identity: 00000000000000bb\nadopted_from: {identity: 00000000000000aa}\n"
    )
    jobs = [{"stages": {"mid": str(run)}, "eval_wall_s": 0.0, "threads": 1} for run in (old, new)]
    cost = measured_cost(as_results(jobs), cores=2)
    assert (cost["stages"], cost["training_core_h"]) == (1, 1.0)


def test_a_stage_every_job_recorded_costs_its_record_and_one_unrecorded_reads_its_log(two_jobs):
    # the logs say a: 1.5 core-h, b: 2 core-h (as above); the records say otherwise, so which one counted shows
    recorded = [{**r, "stage_core_s": {"mid": 360.0, "high": 720.0}} for r in two_jobs]
    cost = measured_cost(as_results(recorded), cores=2)
    assert (cost["training_core_h"], cost["stages_from_records"], cost["unreadable_stages"]) == (0.3, 2, 0)
    # one job records only the mid level: the high level is read from its log
    partial = [{**r, "stage_core_s": {"mid": 360.0}} for r in two_jobs]
    cost = measured_cost(as_results(partial), cores=2)
    assert (cost["training_core_h"], cost["stages_from_records"]) == (2.1, 1)
