"""The paper's experiments as commands: method configs, sweeps through Hydra launchers, resuming, tables."""

from __future__ import annotations

import contextlib
import csv
import fcntl
import io
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from conftest import MAPUSH
from omegaconf import OmegaConf

from mapush.config import group_file, group_options
from mapush.experiments.results import RESULT
from mapush.experiments.stage_plan import iterations_for, stages_with_overrides
from mapush.experiments.workers import GRACE_S
from mapush.logging.mcap_files import THREADS_TAG, summary, training_scalars
from mapush.report.cells import PAPER
from mapush.rundir import find_runs

SMOKE = ["budget=smoke", "debug=smoke"]
SMOKE_EPISODE = "level.episode_length_s=1"
"""What the OCB ablation's smoke budget adds to each of its evaluations."""


def _sweep(cli, tmp_path, *args):
    return cli("sweep", *SMOKE, f"sweep_root={tmp_path / 'sweeps'}", *args)


def _results(root: Path) -> dict[str, dict]:
    return {p.parent.name: json.loads(p.read_text()) for p in root.glob(f"**/{RESULT}")}


@pytest.mark.slow
def test_every_method_trains_one_iteration_per_stage_and_evaluates_2_episodes(cli, tmp_path):
    methods = group_options("method")
    proc = _sweep(cli, tmp_path, "experiment=main", f"method={','.join(methods)}", "task=cuboid")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    results = _results(tmp_path / "sweeps")
    assert sorted(r["method"] for r in results.values()) == sorted(methods)
    for result in results.values():
        stages = {"ml": {"mid"}, "ml_ft": {"mid"}, "hl": {"high"}, "hl_ft": {"high"}}.get(
            result["method"], {"mid", "high"}
        )
        assert set(result["stages"]) == stages
        assert set(result["stage_core_s"]) == stages and all(s > 0 for s in result["stage_core_s"].values())
        assert result["evals"]["main"]["episodes"] == 2
        # the path-only references are evaluated for Ours and H+L (the scripted pusher), the ladder's rungs (the
        # legged Go1s among them) for Ours and SA
        rungs = set(group_file("ladder", "rungs")) if result["method"] in ("ours", "sa") else set()
        path_only = {"path_only"} if result["method"] in ("ours", "hl") else set()
        assert "go1" in set(group_file("ladder", "rungs"))
        assert set(result["evals"]) == {"main", *rungs, *path_only}
        assert 0.0 <= result["evals"]["main"]["success_rate"] <= 1.0
        for run_dir in map(Path, result["stages"].values()):
            assert sorted(p.name for p in run_dir.glob("model_*.pt")) == ["model_0.pt"]  # one iteration
    by_method = {r["method"]: r for r in results.values()}
    assert by_method["sa"]["num_agents"] == 1 and by_method["ours"]["num_agents"] == 2
    high_cfg = (Path(by_method["ours"]["stages"]["high"]) / "config.yaml").read_text()
    assert f"mid: {by_method['ours']['stages']['mid']}" in high_cfg  # the high level sits on this job's mid run
    for method in ("ours_no_ocb", "ml"):
        assert "ocb: null" in (Path(by_method[method]["stages"]["mid"]) / "config.yaml").read_text()
    ml_ft = (Path(by_method["ml_ft"]["stages"]["mid"]) / "config.yaml").read_text()
    assert "name: mid_long" in ml_ft and "occlusion_based" in ml_ft  # the long map, OCB kept
    hl, hl_ft = ((Path(by_method[m]["stages"]["high"]) / "config.yaml").read_text() for m in ("hl", "hl_ft"))
    assert "name: high_nav" in hl and "occlusion_based" not in hl  # robots' own goals, task + penalty rewards
    assert "name: high_nav" in hl_ft and "occlusion_based" in hl_ft  # plus the heuristic terms


def _check_ocb_results(sweeps: Path) -> None:
    """The two smoke jobs of experiment=ocb_ablation finished with both of its evaluations."""
    results = _results(sweeps)
    assert sorted(r["method"] for r in results.values()) == ["ours", "ours_no_ocb"]
    for result in results.values():
        assert set(result["evals"]) == set(group_file("experiment", "ocb_ablation").evals) >= {"t20", "t40"}
        for name, seconds in (("t20", 20), ("t40", 40)):  # each its own timeout, then the smoke budget's 1 s
            assert result["evals"][name]["overrides"] == [f"level.episode_length_s={seconds}", SMOKE_EPISODE]
            assert result["evals"][name]["timeout_s"] == 1.0
        assert result["variant"].startswith("smoke_debug-smoke")


@pytest.mark.slow
def test_a_2_job_sweep_runs_on_submitit_and_lists_its_results(cli, tmp_path):
    """The default launcher (joblib's) runs every other sweep of these tests."""
    proc = _sweep(cli, tmp_path, "experiment=ocb_ablation", "launcher=submitit_local")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "2 jobs finished, 0 failed" in proc.stdout
    _check_ocb_results(tmp_path / "sweeps")
    assert list((tmp_path / "sweeps").glob("*/.submitit"))


@pytest.mark.slow
def test_a_rerun_skips_finished_jobs_and_resumes_a_cut_stage_and_the_archive_rebuilds_the_table(cli, tmp_path):
    three = "experiment.budgets.smoke.stages.mid.env_steps=96"  # 3 iterations of 4 envs x 8 steps
    assert _sweep(cli, tmp_path, "experiment=ocb_ablation", three).returncode == 0
    jobs = {p.parent.name: p.parent for p in (tmp_path / "sweeps").glob(f"**/{RESULT}")}
    finished, cut = sorted(jobs)
    kept = (jobs[finished] / RESULT).read_text()
    # cut the other job after its second iteration's checkpoint: no last checkpoint, policy or result
    mid_run = Path(json.loads((jobs[cut] / RESULT).read_text())["stages"]["mid"])
    stage_dir = mid_run.parents[2]  # the stage's store dir: <stages>/<identity>/mid/<task>/<run>
    for name in (RESULT, "mid_run/model_2.pt", "mid_run/policy.pt"):
        (jobs[cut] / name if name == RESULT else mid_run / name.split("/")[1]).unlink()
    # as if cut on a machine of 3 cores: the resumed iterations run with this job's threads, and record them
    config = OmegaConf.load(mid_run / "config.yaml")
    job_threads = config.sim.nthread
    config.sim.nthread = 3
    OmegaConf.save(config, mid_run / "config.yaml")
    proc = _sweep(cli, tmp_path, "experiment=ocb_ablation", three)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (jobs[finished] / RESULT).read_text() == kept  # not run again
    assert (mid_run / "model_2.pt").is_file() and (mid_run / "policy.pt").is_file()  # resumed in the same run dir
    assert find_runs(stage_dir) == [mid_run]
    assert json.loads((jobs[cut] / RESULT).read_text())["stages"]["mid"] == str(mid_run)
    assert "Learning iteration 2/3" in (mid_run / "train.log").read_text()
    assert training_scalars(mid_run, prefix="Perf/")[THREADS_TAG][2] == job_threads != 3
    _check_ocb_results(tmp_path / "sweeps")
    # the archive rebuilds the table once the runs are gone
    archived = cli("archive", "--runs", tmp_path / "sweeps", "--out", tmp_path / "jobs")
    assert archived.returncode == 0 and "2 results written, 0 already archived" in archived.stdout
    shutil.rmtree(tmp_path / "sweeps")
    proc = cli("tables", "--runs", tmp_path / "jobs", "--out", tmp_path / "out", "--table", "ocb_ablation")
    assert proc.returncode == 0, proc.stderr
    (sidecar,) = (tmp_path / "out").glob("ocb_ablation_smoke_debug-smoke*.json")
    side = json.loads(sidecar.read_text())
    filled = [c for c in side["cells"] if c["mean"] is not None]
    assert filled and all(str(tmp_path / "jobs") in source for c in filled for source in c["sources"])
    assert side["cost"]["stages_from_records"] == 2 and side["cost"]["unreadable_stages"] == 0


@pytest.mark.slow
def test_a_failed_job_does_not_stop_the_others_and_is_listed(cli, tmp_path):
    # a value that composes and passes the checks but breaks PPO when training starts: both jobs fail
    proc = _sweep(cli, tmp_path, "experiment=ocb_ablation", "method=ours,ours_no_ocb", "algo.algorithm.optimizer=nope")
    assert proc.returncode == 1
    assert "0 jobs finished, 2 failed" in proc.stdout and "FAILED" in proc.stdout
    assert len(list((tmp_path / "sweeps").glob("**/failed.txt"))) == 2


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["method=ours,nope"], "nope"),
        (["launcher=moon"], "moon"),
        (["experiment=table9"], "table9"),
        (["budget=huge"], "huge"),
        (["task=sphere"], "sphere"),
    ],
)
def test_a_bad_sweep_fails_before_launching_anything(cli, tmp_path, args, named):
    proc = _sweep(cli, tmp_path, "experiment=ocb_ablation", *args)
    assert proc.returncode == 2
    assert named in proc.stderr and "valid" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "sweeps").exists()


@pytest.mark.slow
def test_scale_rejects_an_agent_count_the_task_cannot_hold(cli, tmp_path):
    proc = cli("scale", "--agents", "1,40", *SMOKE, f"sweep_root={tmp_path / 'sweeps'}")
    assert proc.returncode == 2
    assert "num_agents=40" in proc.stderr and "valid" in proc.stderr
    assert not (tmp_path / "sweeps").exists()


def test_stage_plan_follows_the_method_and_stops_at_the_evaluated_stage(cfg_for):
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from mapush.config import CONF_DIR

    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="sweep", overrides=["experiment=ocb_ablation", "method=sa", "task=ocb_cuboid"])
    plan = stages_with_overrides(cfg)
    assert [name for name, _ in plan] == ["mid"]  # the ablation evaluates the mid level
    # the method's overrides, then the experiment's (the paper's experiments: the original's rules), then the stage's
    assert plan[0][1][:3] == ["task.num_agents=1", "rules=original", "level=mid"]
    assert "num_envs=500" in plan[0][1]  # the quick budget's envs
    # env-steps become iterations: 6e6 / (200 envs x 24 steps) = 1250
    assert iterations_for(cfg_for("num_envs=200"), 6.0e6) == 1250
    # a high-level iteration of 64 envs x 32 decisions x 25 control steps
    assert iterations_for(cfg_for("level=high", "num_envs=64"), 2.0e6) == 40


def test_an_experiments_own_overrides_reach_every_stage_and_its_evaluations_set_each_mass():
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from mapush.config import CONF_DIR

    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="sweep", overrides=["experiment=team", "task=cylinder", "agents=4"])
    plan = stages_with_overrides(cfg)
    assert [name for name, _ in plan] == ["mid"]  # the team study stops at the mid level
    assert all(o in plan[0][1] for o in cfg.experiment.overrides) and "task.num_agents=4" in plan[0][1]
    assert any(o.startswith("task.object.mass_range=") for o in cfg.experiment.overrides)  # trained over a range
    for spec in cfg.experiment.evals.values():  # evaluated at one mass each, the range switched off
        assert spec.overrides[0] == "task.object.mass_range=null" and spec.overrides[1].startswith("task.object.mass=")
    # the stage's policy sees each episode's mass (ln kg) as its last input, the critic too, at one mass in evaluation
    import numpy as np

    from mapush.config import compose_config, to_plain
    from mapush.envs.mid import MidPushEnv
    from mapush.envs.observations import global_dim, local_dim

    stage = [o for o in plan[0][1] if not o.startswith("num_envs=")]
    for extra, masses in ([], None), (list(cfg.experiment.evals.m8.overrides), 8.0):
        env = MidPushEnv(to_plain(compose_config([*stage, *extra, "debug=smoke"])), num_envs=16)
        obs, kg = env.observations(), env.sim.batch.expand("body_mass")[:, env.sim.object_body]
        assert obs["policy"].shape == (16, 4, local_dim(4) + 1) and obs["critic"].shape == (16, 4, global_dim(4) + 1)
        for group in obs.values():
            np.testing.assert_allclose(group[..., -1].exp().numpy(), np.repeat(kg[:, None], 4, 1), rtol=1e-5)
        assert np.all(kg == masses) if masses else kg.max() / kg.min() > 2  # drawn per episode in training


@pytest.mark.slow
def test_reproduce_plans_every_experiment_and_refuses_an_experiment_override(cli, tmp_path):
    root = tmp_path / "sweeps"
    proc = cli("reproduce", "--dry-run", *SMOKE, f"sweep_root={root}", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    planned = [line.split(":")[0] for line in proc.stdout.splitlines() if line.startswith("sweep ")]
    assert planned == [f"sweep {root}/{name}_smoke_debug-smoke" for name in ("main", "scale", "ocb_ablation")]
    assert not root.exists() and not (tmp_path / "out").exists()  # a dry run writes nothing
    bad = cli("reproduce", "experiment=main", *SMOKE, f"sweep_root={root}")
    assert bad.returncode == 2
    last = bad.stderr.strip().splitlines()[-1]
    assert last.endswith(
        "experiment=main: reproduce runs every experiment on its own axes; valid: other overrides "
        "(budget=, seed=, launcher=, sweep_root=, stage overrides)"
    )
    late = cli("reproduce", *SMOKE, f"sweep_root={root}", "agents_typo=3")  # wrong for every sweep: none starts
    assert late.returncode == 2 and "agents_typo" in late.stderr
    assert not root.exists()


def test_an_evaluation_of_a_stage_the_method_does_not_train_is_refused_before_training():
    from omegaconf import OmegaConf

    from mapush.config import compose_config
    from mapush.errors import BadInput
    from mapush.experiments.stage_plan import eval_stage

    cfg = compose_config(["experiment=scale", "method=ours", "task=cylinder", "agents=3"], config_name="sweep")
    OmegaConf.update(cfg, "experiment.evals.mid", {"stage": "mid", "overrides": []}, force_add=True)
    *whole, added = [eval_stage(cfg, spec) for spec in cfg.experiment.evals.values()]  # main, the ladder's rungs
    assert set(whole) == {"high"} and added == "mid"
    ablation = compose_config(["experiment=ocb_ablation", "method=ours", "task=ocb_cuboid"], config_name="sweep")
    OmegaConf.update(ablation, "experiment.evals.bad", {"stage": "high", "overrides": []}, force_add=True)
    with pytest.raises(BadInput, match="evaluation 'bad' runs stage 'high', which its 'ours' jobs do not train "
                                       r"\(they stop at 'mid'\); valid stages: mid"):  # fmt: skip
        stages_with_overrides(ablation)


# ---------------------------------------------------------------------------------------------------------------
def _fixture_result(
    root: Path,
    table: str,
    method: str,
    task: str,
    seed: int,
    evals: dict,
    agents: int = 2,
    mid: float | None = None,
    falls: float | None = None,
) -> None:
    """A finished job's result; `mid`: the success rate at the last point of its mid level's own curve; `falls`: the
    share of every evaluation's episodes a fall ended (None: the records name no exceptions)."""
    job = root / f"{table}_quick" / f"method={method},seed={seed},task={task},agents={agents}"
    job.mkdir(parents=True)
    result = {
        "table": table,
        "variant": "quick",
        "method": method,
        "task": task,
        "num_agents": agents,
        "seed": seed,
        "evals": {
            name: {"success_rate": sr, "completion_time": ct, "completion_time_s": cts}
            | ({} if falls is None else {"exceptions": {"robot_tilt": falls, "robot_collision": 0.0}})
            for name, (sr, ct, cts) in evals.items()
        },
    }
    if mid is not None:
        points = [{"iteration": k, "env_steps": 1e6 * (k + 1), "success_rate": sr} for k, sr in enumerate((0.1, mid))]
        rule = {"tail": 0.2, "max_gain": 0.03}
        result["stage_curves"] = {"mid": {"every_env_steps": 1e6, "rule": rule, "points": points}}
    (job / RESULT).write_text(json.dumps(result))


@pytest.fixture
def fixture_tables(tmp_path):
    runs = tmp_path / "runs"
    # main: ours on the cuboid over 2 seeds; SA on the cylinder over 1 seed; everything else missing
    _fixture_result(runs, "main", "ours", "cuboid", 0, {"main": (0.80, 0.60, 96.0), "path_only": (0.9, 0.5, 80.0)})
    _fixture_result(runs, "main", "ours", "cuboid", 1, {"main": (0.70, 0.70, 112.0), "path_only": (0.8, 0.6, 96.0)})
    _fixture_result(runs, "main", "sa", "cylinder", 0, {"main": (0.10, 0.95, 152.0)}, agents=1)
    # OCB ablation: ours over 2 seeds, the no-OCB variant never ran
    for seed, (sr20, s20, sr40, s40) in enumerate([(0.5, 15.0, 0.7, 22.0), (0.6, 14.0, 0.8, 20.0)]):
        evals = {"t20": (sr20, s20 / 20, s20), "t40": (sr40, s40 / 40, s40)}
        _fixture_result(runs, "ocb_ablation", "ours", "ocb_cuboid", seed, evals)
    # scale: 1 and 3 robots; the 3-robot jobs with their mid levels' own curves and the falls that ended episodes
    _fixture_result(runs, "scale", "ours", "cylinder", 0, {"main": (0.2, 0.9, 0.0)}, agents=1)
    _fixture_result(runs, "scale", "ours", "cylinder", 0, {"main": (0.6, 0.5, 0.0)}, agents=3, mid=0.7, falls=0.3)
    _fixture_result(runs, "scale", "ours", "cylinder", 1, {"main": (0.8, 0.4, 0.0)}, agents=3, mid=0.74, falls=0.5)
    return runs


@pytest.mark.slow
def test_tables_from_fixture_runs_hold_hand_computed_cells_and_mark_the_missing(cli, tmp_path, fixture_tables):
    proc = cli("tables", "--runs", fixture_tables, "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "out"
    assert "main_quick.{md,tex,csv,json}: 6/60 cells filled" in proc.stdout
    assert "scale_quick.{md,tex,csv,json}: 6/20 cells filled" in proc.stdout  # 1, 2, 3, 4 and 6 robots x 4

    md = (out / "main_quick.md").read_text()
    # ours, cuboid: S.R. 80 % and 70 % -> 75.0 +- 5.0; C.T. 0.60 and 0.70 -> 0.65 +- 0.05; paper 77.5 +- 3.0, 0.66
    assert "| Cuboid | S.R. (%) \u2191 |" in md
    assert "75.0 \u00b1 5.0 (77.5 \u00b1 3.0)" in md
    assert "0.65 \u00b1 0.05 (0.66 \u00b1 0.04)" in md
    assert "10.0 (1 seed) (0.0 \u00b1 0.0)" in md  # SA on the cylinder, one seed: no std
    assert "\u2014 (4.5 \u00b1 0.3)" in md  # SA on the cuboid: no job
    assert "- sa / cuboid / success_rate: no finished job" in md
    assert "- hl / cuboid / success_rate: no finished job" in md
    # Ours, path only, on the cuboid: 90 % and 80 % -> 85.0 +- 5.0, C.T. 0.55 +- 0.05; the paper has no such row
    head = next(line for line in md.splitlines() if line.startswith("| Task |"))
    assert head.endswith("| Ours | Ours, path only | H+L, path only | Ours, legged | SA, legged |")
    assert "| 75.0 \u00b1 5.0 (77.5 \u00b1 3.0) | 85.0 \u00b1 5.0 |" in md
    assert "| 0.65 \u00b1 0.05 (0.66 \u00b1 0.04) | 0.55 \u00b1 0.05 |" in md
    assert "- Ours, path only / tblock / success_rate: no finished job" in md
    assert "- Ours, legged / cuboid / success_rate: no finished job" in md

    tex = (out / "main_quick.tex").read_text()
    assert "\\toprule" in tex and "\\midrule" in tex and "\\bottomrule" in tex
    assert "75.0 $\\pm$ 5.0 (77.5 $\\pm$ 3.0)" in tex and "-- (4.5 $\\pm$ 0.3)" in tex

    rows = list(csv.DictReader(io.StringIO((out / "main_quick.csv").read_text())))
    ours_sr = next(r for r in rows if r["row"] == "Cuboid / S.R. (%) \u2191" and r["column"] == "Ours")
    assert float(ours_sr["mean"]) == pytest.approx(75.0) and float(ours_sr["std"]) == pytest.approx(5.0)
    assert ours_sr["seeds"] == "2" and float(ours_sr["paper_mean"]) == 77.5
    assert len(ours_sr["sources"].split(";")) == 2
    empty = next(r for r in rows if r["row"] == "Cuboid / S.R. (%) \u2191" and r["column"] == "SA")
    assert empty["mean"] == "" and empty["seeds"] == "0"

    side = json.loads((out / "main_quick.json").read_text())
    cell = next(c for c in side["cells"] if c["row"][0] == "Cuboid" and c["column"] == "Ours" and "S.R." in c["row"][1])
    assert all(Path(s).is_dir() for s in cell["sources"]) and len(cell["sources"]) == 2

    ocb = (out / "ocb_ablation_quick.md").read_text()
    # S.R. at 20 s: 50 % and 60 % -> 55.0 +- 5.0; C.T. at 40 s: 22 s and 20 s -> 21.0 +- 1.0
    assert "| Ours | 55.0 \u00b1 5.0 (57.0 \u00b1 6.1) | 14.5 \u00b1 0.5 (14.9 \u00b1 0.8) |" in ocb
    assert "21.0 \u00b1 1.0 (22.5 \u00b1 2.4)" in ocb
    assert "| Ours w/o OCB | \u2014 (13.0 \u00b1 1.2) |" in ocb

    scale = (out / "scale_quick.md").read_text()
    # 3 robots: hierarchy 60 and 80 % -> 70.0 +- 10.0, C.T. 0.45 +- 0.05; mid level 70 and 74 % -> 72.0 +- 2.0
    # falls 30 and 50 % of the 3-robot episodes: 40.0 +- 10.0; the 1-robot record names no exceptions: no cell
    assert "| 3 | 70.0 \u00b1 10.0 | 0.45 \u00b1 0.05 | 72.0 \u00b1 2.0 | 40.0 \u00b1 10.0 |" in scale
    assert "| 1 | 20.0 (1 seed) | 0.90 (1 seed) | \u2014 | \u2014 |" in scale
    side = json.loads((out / "scale_quick.json").read_text())
    found = {(f["key"], f["about"]): f for f in side["findings"]}
    best = found["three_best", "whole hierarchy"]  # of those finished, 1 and 3 robots: 3 the highest
    assert best["holds"] is True and best["numbers"] == pytest.approx({"1 robot": 20.0, "3 robots": 70.0})
    reference = found["reference_mid", "3 robots"]  # 72.0 +- 2.0 against 72.3: short by 0.3, within the std
    assert reference["holds"] is None
    assert reference["numbers"] == pytest.approx({"left": 72.0, "right": 72.3, "spread": 2.0})
    assert "2 robots: no finished job: S.R. (%) \u2191, C.T. \u2193, Falls (%) \u2193" in side["missing"]
    assert "| 6 | \u2014 | \u2014 | \u2014 | \u2014 |" in scale  # planned, not run
    assert "6 robots: no finished job: S.R. (%) \u2191, C.T. \u2193, Falls (%) \u2193" in side["missing"]
    assert "1 robot: no curve of the mid level: Mid level S.R. (%) \u2191" in side["missing"]
    assert (out / "scale_quick.png").stat().st_size > 1000


def test_tables_with_no_runs_are_still_written_with_every_cell_missing(cli, tmp_path):
    (tmp_path / "runs").mkdir()
    proc = cli("tables", "--runs", tmp_path / "runs", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert "main_quick.{md,tex,csv,json}: 0/60 cells filled" in proc.stdout  # 6 methods and 4 columns beside
    assert "team_quick.{md,tex,csv,json}: 0/32 cells filled" in proc.stdout  # 2 objects x 4 teams x 4 masses
    assert "\u2014 (77.5 \u00b1 3.0)" in (tmp_path / "out" / "main_quick.md").read_text()


def test_a_table_with_more_filled_cells_than_the_runs_give_is_kept_unless_overwritten(cli, tmp_path, fixture_tables):
    out = tmp_path / "out"
    assert cli("tables", "--runs", fixture_tables, "--out", out, "--table", "main").returncode == 0
    before = (out / "main_quick.md").read_text()
    (tmp_path / "empty").mkdir()  # the runs are gone
    proc = cli("tables", "--runs", tmp_path / "empty", "--out", out, "--table", "main")
    assert proc.returncode == 0, proc.stderr
    assert "main_quick.{md,tex,csv,json}: kept as it was (6 cells filled; these runs give 0; --overwrite" in proc.stdout
    assert (out / "main_quick.md").read_text() == before
    proc = cli("tables", "--runs", tmp_path / "empty", "--out", out, "--table", "main", "--overwrite")
    assert "0/60 cells filled" in proc.stdout and (out / "main_quick.md").read_text() != before


def test_tables_reject_a_missing_runs_dir(cli, tmp_path):
    proc = cli("tables", "--runs", tmp_path / "nowhere")
    assert proc.returncode == 2 and "nowhere" in proc.stderr and "valid" in proc.stderr


def test_the_paper_numbers_are_read_not_typed_twice():
    assert PAPER["main"]["success_rate"]["cuboid"]["ours"] == [77.5, 3.0]
    assert PAPER["ocb_ablation"]["completion_time_s"]["t40"]["ours_no_ocb"] == [34.9, 0.3]


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_killed_sweep_leaves_no_process_behind_and_resumes(tmp_path, sig):
    """The sweep's workers stop (logs closed, stage locks released) and exit when the sweep dies, even by SIGKILL;
    the same command then resumes the cut stages from their checkpoints."""
    cmd = [*MAPUSH, "sweep", "experiment=ocb_ablation", "budget=quick", "debug=smoke", "seed=0"]
    cmd.append(f"sweep_root={tmp_path / 'sweeps'}")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    sweep = subprocess.Popen(cmd, cwd=tmp_path, env=env, start_new_session=True, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        deadline = time.monotonic() + 240
        while len(list((tmp_path / "sweeps").glob("stages/*/mid/*/*/model_*.pt"))) < 4:  # both jobs are training
            assert time.monotonic() < deadline and sweep.poll() is None
            time.sleep(1)
        sweep.send_signal(sig)
        sweep.wait()
        deadline = time.monotonic() + GRACE_S + 30
        while _group_alive(sweep.pid):
            assert time.monotonic() < deadline, "a worker outlived its sweep"
            time.sleep(1)
    finally:  # whatever failed above, leave nothing running
        with contextlib.suppress(ProcessLookupError):
            os.killpg(sweep.pid, signal.SIGKILL)
    cut = sorted((tmp_path / "sweeps").glob("stages/*/mid/*/*"))
    assert len(cut) == 2 and all(not (run / "policy.pt").exists() for run in cut)
    for run in cut:  # the stage lock is free: another process takes it at once
        with open(run.parents[2] / ".lock") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    dry = subprocess.run([*cmd, "--dry-run"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert dry.returncode == 0 and dry.stdout.count("resume") >= 2, dry.stdout


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.slow
def test_a_sweep_over_the_robot_count_may_name_it_as_the_task_key(cli, tmp_path):
    """`task.num_agents=range(1,4)` is the `agents` axis, as Hydra users would write it."""
    by_axis = _sweep(cli, tmp_path, "experiment=scale", "agents=1,2,3", "--dry-run")
    by_key = _sweep(cli, tmp_path, "experiment=scale", "task.num_agents=range(1,4)", "--dry-run")
    assert by_key.returncode == 0, by_key.stderr
    assert by_key.stdout == by_axis.stdout and "agents=3" in by_key.stdout


@pytest.mark.slow
def test_two_identical_sweeps_at_once_leave_every_episode_file_readable(tmp_path):
    """Stage training is locked and so is evaluation: the second sweep waits, and no file is written twice at once.
    One job each (its stage, its two evaluations), the same job in both."""
    cmd = [*MAPUSH, "sweep", *SMOKE, f"sweep_root={tmp_path / 'sweeps'}", "experiment=ocb_ablation", "method=ours"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    procs = [subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in "ab"]
    for proc in procs:
        assert proc.wait(timeout=900) == 0, proc.stderr.read()
    episode_files = list((tmp_path / "sweeps").glob("**/episodes*.mcap"))
    assert len(episode_files) >= 2  # t20's and t40's
    assert all(summary(path)["complete"] for path in episode_files)
    assert len(_results(tmp_path / "sweeps")) == 1
