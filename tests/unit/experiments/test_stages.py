"""Stages trained once: identity from the composed config, reuse across jobs and experiments, the dry run."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import pytest
from omegaconf import OmegaConf, open_dict
from paths import REPO

from mapush.config import compose_config, group_file, load_run_config
from mapush.errors import BadInput
from mapush.experiments import archive, pipeline, stage_plan, stages
from mapush.experiments.archive import made_otherwise
from mapush.experiments.pipeline import run_job
from mapush.experiments.results import RESULT, SUPERSEDED, JobResult, read_result
from mapush.experiments.stage_plan import planned_stages, stage_budget
from mapush.experiments.stages import compose_stage, identity_of
from mapush.experiments.staleness import result_changes
from mapush.experiments.sweep_axes import sweep_overrides
from mapush.migrations import UNSET_LATER_KEYS
from mapush.rundir import find_runs

SMOKE = ["budget=smoke", "debug=smoke"]
SHIPPED_GO1 = REPO / "mapush" / "lowlevel" / "pretrained" / "go1" / "policy.pt"
SHIPPED_GO1_SHA256 = hashlib.sha256(SHIPPED_GO1.read_bytes()).hexdigest()[:16]
"""How a legged evaluation names the policy that walked its robots (`lowlevel_policy.sha256` in result.json)."""


def _identities(*overrides: str) -> dict[str, str]:
    cfg = compose_config(["experiment=main", "method=ours", "task=cuboid", *overrides], config_name="sweep")
    return {stage.name: stage.identity for stage in planned_stages(cfg)}


def test_stage_overrides_written_as_a_list_are_swept_as_if_given_bare():
    # both spellings make one sweep dir apart from the plain sweep's, and give the stages the same overrides
    bare = sweep_overrides(["method=sa", "task=cuboid", *SMOKE])
    assert sweep_overrides(["method=sa", "task=cuboid", "budget=smoke", "overrides=['debug=smoke']"]) == bare
    assert "overrides=['debug=smoke']" in bare and "sweep_name=${experiment.name}_${budget}_debug-smoke" in bare
    # a robot count in the list is the sweep's axis, as it is given bare
    listed = sweep_overrides(["method=sa", "task=cylinder", "budget=smoke", "overrides=['task.num_agents=2']"])
    assert listed == sweep_overrides(["method=sa", "task=cylinder", "budget=smoke", "task.num_agents=2"])
    assert "agents=2" in listed and not any(o.startswith("overrides=") for o in listed)
    with pytest.raises(BadInput, match=r"bad override 'overrides=\[debug=smoke\]' .*valid: overrides=\['key=value'"):
        sweep_overrides(["method=sa", "task=cuboid", "overrides=[debug=smoke]"])


def test_a_method_file_copied_with_its_name_kept_is_refused(tmp_path, monkeypatch):
    import shutil

    from mapush import config

    conf = tmp_path / "conf"
    shutil.copytree(config.CONF_DIR, conf)
    shutil.copy(conf / "method" / "ours.yaml", conf / "method" / "mine.yaml")  # still `name: ours`
    monkeypatch.setattr(config, "CONF_DIR", conf)
    with pytest.raises(BadInput, match=r"method=mine: its file says name: ours; valid: name: mine"):
        sweep_overrides(["method=mine", "task=cuboid", *SMOKE])


def test_an_experiment_whose_table_no_builder_draws_is_refused_before_it_trains(tmp_path, monkeypatch):
    import shutil

    from mapush import config
    from mapush.commands.experiment_commands import _check_table

    conf = tmp_path / "conf"
    shutil.copytree(config.CONF_DIR, conf)
    mine = OmegaConf.create(OmegaConf.to_container(config.group_file("experiment", "ocb_ablation")))
    mine.name, mine.table = "mine", "mian"  # a typo
    (conf / "experiment" / "mine.yaml").write_text(OmegaConf.to_yaml(mine))
    monkeypatch.setattr(config, "CONF_DIR", conf)
    with pytest.raises(BadInput, match=r"its file says table: mian; valid: ladder, main, ocb_ablation, "):
        _check_table(["experiment=mine", "seed=0"])
    _check_table(["experiment=ocb_ablation"])  # the shipped ones pass, and an unknown one is left to the sweep
    _check_table(["experiment=nosuch"])


def test_equal_stage_configs_have_one_identity_whatever_the_job_that_composes_them():
    # SA's mid level of the cylinder is the scalability study's 1-robot mid level, composed from other overrides
    sa = compose_config(["experiment=main", "method=sa", "task=cylinder"], config_name="sweep")
    scale = compose_config(["experiment=scale", "method=ours", "task=cylinder", "agents=1"], config_name="sweep")
    assert [s.identity for s in planned_stages(sa)] == [s.identity for s in planned_stages(scale)]
    # where a stage is written, with how many threads, how it is logged and how many checkpoints it keeps do not
    # make another stage
    assert _identities() == _identities(
        "overrides=['sim.nthread=1','log.episode_interval=0','train.progress=false','algo.keep_checkpoints=0',"
        "'algo.save_interval=7']"
    )


def test_a_changed_reward_weight_tracker_value_or_budget_is_another_stage():
    base = _identities()
    for changed in (
        "method.stages.mid=['level=mid','reward.terms.ocb.weight=0.01']",
        "overrides=['lowlevel.max_force=40.0']",
        "experiment.budgets.quick.stages.mid.env_steps=5.0e6",
        "seed=1",
    ):
        other = _identities(changed)
        assert other["mid"] != base["mid"], changed
        assert other["high"] != base["high"], changed  # the high level sits on another mid level
    # a high-level change leaves the mid level shared
    high_only = _identities("experiment.budgets.quick.stages.high.env_steps=3.0e6")
    assert high_only["mid"] == base["mid"] and high_only["high"] != base["high"]


def test_a_task_may_have_its_own_stage_budget():
    # experiment/main.yaml gives every task's high levels 5M env-steps; a `by_task` entry gives the T-block's 10M.
    # A high iteration is 128 envs x 32 decisions x 25 control steps = 102,400 env-steps.
    def high(task: str, by_task: dict | None = None):
        cfg = compose_config(["experiment=main", "method=ours", f"task={task}"], config_name="sweep")
        if by_task is not None:
            with open_dict(cfg):
                cfg.experiment.budgets.quick.stages.high.by_task = by_task
        return [s.env_steps for s in planned_stages(cfg)]

    assert high("tblock") == high("cuboid") == [12_000_000, 49 * 102_400]
    longer = {"tblock": {"env_steps": 1.0e7}}
    assert high("tblock", longer) == [12_000_000, 98 * 102_400]
    assert high("cuboid", longer) == [12_000_000, 49 * 102_400]
    cfg = compose_config(["experiment=main", "method=ours", "task=tblock"], config_name="sweep")
    with open_dict(cfg):
        cfg.experiment.budgets.quick.stages.high.by_task = {"tblok": {"env_steps": 1.0e6}}
    with pytest.raises(BadInput, match=r"by_task entry 'tblok'; valid: tasks cuboid, cylinder"):
        planned_stages(cfg)
    with open_dict(cfg):
        cfg.experiment.budgets.quick.stages.high.by_task = {"tblock": {"envsteps": 1.0e6}}
    with pytest.raises(BadInput, match=r"by_task entry 'tblock.envsteps'; valid: .* num_envs and/or env_steps"):
        planned_stages(cfg)


def test_every_method_learns_as_long_as_ours_stages_together():
    """experiment/main.yaml: `same_learning_as: ours`. Ours learns 12M (mid) + 5M (high) env-steps; a method with
    one stage learns those 17M in it; SA, with Ours' stages, learns as Ours does."""

    def learned(method: str, **budget) -> dict[str, float]:
        cfg = compose_config(["experiment=main", f"method={method}", "task=cuboid"], config_name="sweep")
        with open_dict(cfg):
            cfg.experiment.budgets.quick.update(budget)
        return {name: float(stage_budget(cfg, name).env_steps) for name in cfg.method.stages}

    assert learned("ours") == learned("sa") == {"mid": 12e6, "high": 5e6}
    assert learned("hl") == learned("hl_ft") == {"high": 17e6}
    assert learned("ml") == learned("ml_ft") == {"mid": 17e6}
    assert learned("hl", same_learning_as=None) == {"high": 5e6}  # without the rule: the stage's own entry
    with pytest.raises(BadInput, match=r"same_learning_as 'ourz'; valid: .*hl_ft"):
        learned("hl", same_learning_as="ourz")


def test_a_field_of_the_task_on_the_sweep_command_line_reaches_every_stage():
    # `task` is a sweep axis, but a field of it is a stage override: each stage composes its task from the job's
    # task name, so `task.object.friction=...` left among the sweep's keys would be dropped without a word
    full = sweep_overrides(["method=ours", "task=cylinder", "task.object.friction=[0.5,0.6]"])
    assert "task.object.friction=[0.5,0.6]" not in full
    assert "overrides=['task.object.friction=[0.5,0.6]']" in full
    plain = _identities("task=cylinder")
    lighter = _identities("task=cylinder", "overrides=['task.object.friction=[0.5,0.6]']")
    assert lighter["mid"] != plain["mid"] and lighter["high"] != plain["high"]


OLD_REGIME_MID_STAGES = {"cylinder": "0676bfba46653ac6", "tblock": "77f81d1e11fb3bee"}
"""The main table's Ours seed-0 mid levels as trained on 2026-11-26/27 (runs/sweeps/stages/<identity>), with the
tracker of then: a per-axis cap of 35 N, no falls, robot_collision on centre distances."""


def test_the_robots_of_2026_11_28_make_every_stage_new():
    """The calibrated physics (planar cap, falls, collisions of touching footprints) changed what every stage
    learns: none of the stages trained before is reused for it."""
    for task, old in OLD_REGIME_MID_STAGES.items():
        assert _identities(f"task={task}")["mid"] != old


@pytest.mark.parametrize(
    ("key", "default", "other"),
    [
        ("train.init_from", "null", "runs/x"),
        ("lowlevel.force_cap", "axes", "planar"),
        ("lowlevel.fall", "null", "{load_n:50.0,width_n:5.0,window_s:4.0,filter_s:0.2}"),
        ("task.object.mass", "null", "8.0"),
    ],
)
def test_a_key_added_after_stages_were_trained_is_no_part_of_an_identity_at_its_default(key, default, other):
    """`migrations.UNSET_LATER_KEYS`: a key at the value that leaves a stage as it was before the key existed stays
    out of the identity, so a stage made before the key keeps its identity; at another value it is another stage."""
    import copy

    assert key in UNSET_LATER_KEYS

    def stage(value: str) -> dict:
        return compose_stage(["level=mid", "task=cylinder", f"{key}={value}"], lambda c: 10)

    now = stage(default)
    made_before = copy.deepcopy(now)  # the same stage, saved before the key existed
    *parents, leaf = key.split(".")
    node = made_before
    for part in parents:
        node = node[part]
    del node[leaf]
    assert stages.identity(now, [], {}) == stages.identity(made_before, [], {})
    assert stages.identity(stage(other), [], {}) != stages.identity(now, [], {})


def test_a_reward_term_at_weight_0_is_no_term_so_a_task_may_switch_a_new_one_off():
    # robot_jam joined the mid reward after the main table's stages were trained; the T-block, the cylinder and the
    # OCB cuboid weigh it 0 (task.reward_weights.robot_jam), so their stages are those of a reward without it,
    # while on the cuboid, which weighs it, it makes another stage
    for task in ("cylinder", "tblock"):
        deleted = _identities(f"task={task}", "method.stages.mid=['level=mid','~reward.terms.robot_jam']")
        assert _identities(f"task={task}")["mid"] == deleted["mid"]
    off = _identities("task=cuboid", "method.stages.mid=['level=mid','reward.terms.robot_jam.weight=0.0']")
    deleted = _identities("task=cuboid", "method.stages.mid=['level=mid','~reward.terms.robot_jam']")
    assert off == deleted
    assert _identities("task=cuboid")["mid"] != off["mid"]


def test_a_sweep_stage_writes_a_checkpoint_by_every_mark_of_its_learning_curve():
    cfg = compose_config(["experiment=main", "method=ours", "task=cuboid"], config_name="sweep")
    mid, high = planned_stages(cfg)
    # quick budget, curve marks every 2M env-steps. mid: 500 envs x 24 steps = 12,000 env-steps per iteration,
    # 166 iterations between marks, so algo/mappo.yaml's 50 stands. high: 128 envs x 32 decisions x 25 control
    # steps = 102,400 env-steps per iteration, 19 between marks: every 18 iterations instead of ppo_high.yaml's 50,
    # so model_18.pt (19 iterations, 1.95M env-steps) comes before the 2M mark, where model_19.pt (2.05M) would not
    assert (mid.save_interval, high.save_interval) == (50, 18)


def _sweep(cli, root, *args):
    return cli(*args, *SMOKE, f"sweep_root={root}")


@pytest.mark.slow
def test_a_stage_trained_by_one_experiment_is_reused_by_another_and_the_dry_run_says_so(cli, tmp_path, snapshot):
    root = tmp_path / "sweeps"
    plan = _sweep(cli, root, "sweep", "--dry-run", "experiment=main", "method=sa", "task=cylinder")
    assert plan.returncode == 0, plan.stderr
    assert "2 to train" in plan.stdout and plan.stdout.count("  train  ") == 2
    assert not root.exists()  # the dry run trains and writes nothing

    first = _sweep(cli, root, "sweep", "experiment=main", "method=sa", "task=cylinder")
    assert first.returncode == 0, first.stdout + first.stderr
    before = snapshot(root)
    # the study's 1-robot job is that job: the same stages and evaluation (its smoke budget draws no curve)
    plan = _sweep(cli, root, "scale", "--agents", "1", "--dry-run")
    assert plan.returncode == 0, plan.stderr
    assert "1 jobs, 1 finished (1 made already by other sweeps' jobs" in plan.stdout and "0 to train" in plan.stdout
    assert snapshot(root) == before
    taken = _sweep(cli, root, "scale", "--agents", "1")
    assert taken.returncode == 0, taken.stdout + taken.stderr
    assert "its result taken, nothing trained" in taken.stdout
    (made,) = root.glob(f"main_*/*/{RESULT}")
    (twin,) = [json.loads(p.read_text()) for p in root.glob(f"scale_*/*/{RESULT}")]
    main_result = json.loads(made.read_text())
    assert twin["taken_from"] == str(made.parent) and twin["experiment"] == "scale"
    asked = set(twin["evals"])  # what the study asks for: its main evaluation and the ladder's rungs
    assert twin["stages"] == main_result["stages"] and asked == {"main", *group_file("ladder", "rungs")}
    assert all(twin["evals"][name] == main_result["evals"][name] for name in asked)

    # an evaluation the main job lacks (the mid level alone): the stages are reused, that evaluation made
    extra = "+experiment.evals.mid={stage:mid,overrides:[]}"
    plan = _sweep(cli, root, "scale", "--agents", "1", "--dry-run", extra)
    assert "0 to train" in plan.stdout and plan.stdout.count("  reuse  ") == 2
    second = _sweep(cli, root, "scale", "--agents", "1", extra)
    assert second.returncode == 0, second.stdout + second.stderr
    results = [json.loads(p.read_text()) for p in sorted(root.glob(f"*/*/{RESULT}"))]
    assert sorted(r["experiment"] for r in results) == ["main", "scale", "scale"]
    assert all(r["stages"] == main_result["stages"] for r in results)  # every cell names the same run dirs
    (alone,) = [r for r in results if "mid" in r["evals"]]
    mid_eval = Path(alone["evals"]["mid"]["file"])
    assert mid_eval.parent == Path(alone["stages"]["mid"]) and mid_eval.name == "eval_mid.json"
    assert len(find_runs(root / "stages")) == 2  # one mid and one high run in all
    for run in map(Path, results[0]["stages"].values()):
        assert sorted(p.name for p in run.glob("model_*.pt")) == ["model_0.pt"]  # trained once, not resumed

    # the main budget asks for the mid level's own curve too: drawn once, into the mid run, and kept in the result
    mid_curve = results[0]["stage_curves"]["mid"]
    assert [p["iteration"] for p in mid_curve["points"]] == [0] and "high" not in results[0]["stage_curves"]
    drawn = Path(results[0]["stages"]["mid"]) / pipeline.STAGE_CURVE
    assert json.loads(drawn.read_text())["points"] == mid_curve["points"]
    assert results[1].get("stage_curves", {}) == {}  # the scale smoke budget asks for none
    # a job finished before its budget asked for the stage's curve gets it on the next run, read, not drawn again
    main_result = next(p for p in root.glob(f"main_*/*/{RESULT}"))
    lacking = json.loads(main_result.read_text())
    del lacking["stage_curves"]
    main_result.write_text(json.dumps(lacking))
    drawn_at = drawn.stat().st_mtime_ns
    again = _sweep(cli, root, "sweep", "experiment=main", "method=sa", "task=cylinder")
    assert again.returncode == 0, again.stdout + again.stderr
    assert json.loads(main_result.read_text())["stage_curves"]["mid"] == mid_curve
    assert drawn.stat().st_mtime_ns == drawn_at


def _stored(root: Path, stage, iterations: int, finished: bool = True) -> Path:
    """A stage of `stage`'s config at `iterations` in the store at `root`, with a run (nothing trained): finished
    (its exported policy there) or cut."""
    cfg = json.loads(json.dumps(stage.cfg))
    cfg["train"]["iterations"] = iterations
    key = stages.identity(cfg, [], {})
    stages.write_identity(stages.stage_dir(root, key), cfg, key)
    run = stages.stage_dir(root, key) / "mid" / "cylinder" / f"run{iterations}"
    run.mkdir(parents=True)
    (run / "meta.json").write_text("{}")
    if finished:
        (run / "policy.pt").write_bytes(b"")
    return run


def test_the_shorter_twin_of_a_stage_is_the_longest_finished_run_of_it_with_fewer_iterations(tmp_path):
    root = tmp_path / "sweeps"
    mid, _high = planned_stages(_job_cfg(root))
    asked = json.loads(json.dumps(mid.cfg))
    asked["train"]["iterations"] = 10
    assert stages.shorter_twin(root, asked, mid.overrides, {}) is None  # an empty store
    _stored(root, mid, 3)
    longest = _stored(root, mid, 6)
    _stored(root, mid, 8, finished=False)  # cut: nothing to train on from
    _stored(root, mid, 12)  # longer than asked
    other_seed = planned_stages(_job_cfg(root, "seed=1"))[0]
    _stored(root, other_seed, 7)  # another seed is another stage
    assert stages.shorter_twin(root, asked, mid.overrides, {}) == longest
    assert stages.shorter_twin(root, mid.cfg, mid.overrides, {}) is None  # nothing shorter than its 1 iteration


def test_a_stage_built_on_another_has_a_shorter_twin_only_on_that_same_stage(tmp_path):
    root = tmp_path / "sweeps"
    mid, high = planned_stages(_job_cfg(root))
    mid_run = _stored(root, mid, mid.iterations)
    on_mid = json.loads(json.dumps(high.cfg))
    on_mid["mid"], on_mid["train"]["iterations"] = str(mid_run), 1
    key = stages.identity(on_mid, high.overrides, {"mid": mid.identity})
    stages.write_identity(stages.stage_dir(root, key), on_mid, key)
    twin = stages.stage_dir(root, key) / "high" / "cylinder" / "run"
    twin.mkdir(parents=True)
    (twin / "meta.json").write_text("{}")
    (twin / "policy.pt").write_bytes(b"")
    longer = json.loads(json.dumps(high.cfg))
    longer["train"]["iterations"] = 5
    assert stages.shorter_twin(root, longer, high.overrides, {"mid": mid.identity}) == twin
    assert stages.shorter_twin(root, longer, high.overrides, {"mid": "another-mid-stage"}) is None


@pytest.mark.slow
def test_a_lengthened_budget_trains_the_shorter_stage_on_and_the_dry_run_says_so(cli, tmp_path):
    # the smoke budget's mid level: 1 iteration of 4 envs x 8 steps; at 96 env-steps it is 3 iterations
    root = tmp_path / "sweeps"
    job = ["experiment=main", "method=sa", "task=cylinder"]
    first = _sweep(cli, root, "sweep", *job)
    assert first.returncode == 0, first.stdout + first.stderr
    (short,) = [Path(json.loads(p.read_text())["stages"]["mid"]) for p in root.glob(f"*/*/{RESULT}")]
    longer = [*job, "experiment.budgets.smoke.stages.mid.env_steps=96"]
    plan = _sweep(cli, root, "sweep", "--dry-run", *longer)
    assert plan.returncode == 0, plan.stderr
    assert "train on 1/3" in plan.stdout and "2 to train" in plan.stdout
    done = _sweep(cli, root, "sweep", *longer)
    assert done.returncode == 0, done.stdout + done.stderr
    (result,) = [json.loads(p.read_text()) for p in root.glob(f"*/*mid.env_steps=96*/{RESULT}")]
    run = Path(result["stages"]["mid"])
    assert run != short and stages.identity_of(run) != stages.identity_of(short)
    record = stages.read_identity(run.parents[2] / stages.IDENTITY_FILE)
    assert record["lengthened_from"] == {"identity": stages.identity_of(short), "iterations": 1}
    assert sorted(p.name for p in run.glob("model_*.pt")) == ["model_0.pt", "model_1.pt", "model_2.pt"]
    assert (run / "model_0.pt").stat().st_ino == (short / "model_0.pt").stat().st_ino  # trained on, not again
    assert load_run_config(run).train.iterations == 3 and (run / "policy.pt").is_file()
    (step,) = json.loads((run / "meta.json").read_text())["lengthened"]
    assert (step["from_iterations"], step["to_iterations"]) == (1, 3)
    assert load_run_config(short).train.iterations == 1  # the shorter stage is left as it was
    assert sorted(p.name for p in short.glob("model_*.pt")) == ["model_0.pt"] and (short / "policy.pt").is_file()
    # the lengthened stage's own curve reaches its end (the smoke curve's one mark, 800 env-steps, lies past it)
    assert [p["iteration"] for p in result["stage_curves"]["mid"]["points"]] == [2]
    # its job's result gone, the dry run reuses the lengthened stage: finished, not one to train on again
    next(root.glob(f"*/*mid.env_steps=96*/{RESULT}")).unlink()
    again = _sweep(cli, root, "sweep", "--dry-run", *longer)
    assert "0 to train" in again.stdout and "train on" not in again.stdout, again.stdout


@pytest.mark.slow
def test_runs_trained_by_hand_as_a_sweeps_stages_are_adopted_and_reused(cli, tmp_path):
    # a probe trained with `mapush train` and the recipe's config is that stage: `mapush stages adopt` puts it in the
    # store, and the sweep trains nothing. The high run named its mid run by path: its copy names the adopted one
    root = tmp_path / "sweeps"
    job = ["experiment=main", "method=sa", "task=cylinder"]
    mid, high = planned_stages(_job_cfg(root))
    made = {}
    for stage in (mid, high):
        overrides = [o.replace("@mid", str(made.get("mid", ""))) for o in stage.overrides]
        done = cli(
            "train", *overrides, f"train.iterations={stage.iterations}", f"train.run_dir={tmp_path / stage.name}"
        )
        assert done.returncode == 0, done.stderr
        made[stage.name] = tmp_path / stage.name
    unrelated = cli("train", "debug=smoke", "task=cuboid", f"train.run_dir={tmp_path / 'other'}")
    assert unrelated.returncode == 0, unrelated.stderr

    runs = [arg for run in (made["high"], tmp_path / "other", made["mid"]) for arg in ("--run", run)]
    proc = _sweep(cli, root, "stages", "adopt", *runs, *job)
    assert proc.returncode == 0, proc.stderr
    assert f"not adopted (no planned stage without a run has its config): {tmp_path / 'other'}" in proc.stdout
    (mid_copy,), (high_copy,) = (find_runs(stages.stage_dir(root, s.identity)) for s in (mid, high))
    assert load_run_config(high_copy).mid == str(mid_copy.resolve())  # the high run names the adopted mid run
    plan = _sweep(cli, root, "sweep", "--dry-run", *job)
    assert plan.returncode == 0, plan.stderr
    assert "0 to train" in plan.stdout and plan.stdout.count("  reuse  ") == 2
    done = _sweep(cli, root, "sweep", *job)
    assert done.returncode == 0, done.stdout + done.stderr
    (result,) = [json.loads(p.read_text()) for p in root.glob(f"*/*/{RESULT}")]
    assert {name: Path(path).resolve() for name, path in result["stages"].items()} == {
        "mid": mid_copy.resolve(),
        "high": high_copy.resolve(),
    }


def _job_cfg(root: Path, *overrides: str):
    return compose_config(
        ["experiment=main", "method=sa", "task=cylinder", "budget=smoke", "overrides=['debug=smoke']",
         f"sweep_root={root}", *overrides],
        config_name="sweep",
    )  # fmt: skip


def _fake_result(cfg, identities: dict[str, str]) -> dict:
    """A finished job's result whose stage runs lie in the store under `identities` (nothing trained), with the
    evaluations the experiment asks of its method; a legged one names the shipped Go1 policy that walked it."""
    store = Path(cfg.sweep_root) / "stages"
    evals = {}
    for name, spec in cfg.experiment.evals.items():
        if stage_plan.applies(spec, cfg.method.name):
            legged = "lowlevel=go1" in stage_plan.eval_overrides(cfg, name)
            walker = {"lowlevel_policy": {"sha256": SHIPPED_GO1_SHA256}} if legged else {}
            evals[name] = {"success_rate": 0.5, **walker}
    return {
        "stages": {name: str(store / key / name / "cylinder" / "run") for name, key in identities.items()},
        "evals": evals,
        "curve": {"points": []},
    }


@pytest.mark.slow
def test_a_finished_job_made_by_other_stages_is_listed_and_kept_or_run_again(cli, tmp_path):
    root = tmp_path / "sweeps"
    args = ["sweep", "--dry-run", "experiment=main", "method=sa", "task=cylinder", *SMOKE, f"sweep_root={root}"]
    plan = cli(*args)
    assert plan.returncode == 0, plan.stderr
    sweep_dir = Path(plan.stdout.split(":")[0].removeprefix("sweep "))
    job = sweep_dir / "method=sa,seed=0,task=cylinder"
    job.mkdir(parents=True)
    cfg = _job_cfg(root)
    now = {stage.name: stage.identity for stage in planned_stages(cfg)}

    (job / RESULT).write_text(json.dumps(_fake_result(cfg, now)))  # made by the stages planned now
    plan = cli(*args)
    assert "1 jobs, 1 finished; 0 stages to run" in plan.stdout and "were made by" not in plan.stdout

    # made when the high level's budget was another: listed, kept by default, trained again on request
    (job / RESULT).write_text(json.dumps(_fake_result(cfg, {**now, "high": "00000000feedbeef"})))
    plan = cli(*args)
    assert "1 jobs, 1 finished; 0 stages to run" in plan.stdout
    assert f"its stages changed (high: 00000000feedbeef -> {now['high']})" in plan.stdout
    assert "kept as they are (rerun_changed=true runs them again)" in plan.stdout
    plan = cli(*args, "rerun_changed=true")
    assert "they run again" in plan.stdout and "2 stages to run; 2 to train" in plan.stdout
    # the planned stage was adopted from that one (`mapush stages rekey`: the same run, a config of another form)
    record = root / "stages" / now["high"] / "stage.yaml"
    record.parent.mkdir(parents=True)
    record.write_text(f"identity: {now['high']}\nadopted_from: {{identity: 00000000feedbeef}}\n")
    assert "were made by" not in cli(*args).stdout
    record.unlink()

    # an evaluation the experiment now asks for and the result lacks
    stale = _fake_result(cfg, now)
    stale["evals"] = {"old_name": {"success_rate": 0.5}}
    (job / RESULT).write_text(json.dumps(stale))
    asked = ", ".join(sorted(["main", *group_file("ladder", "rungs")]))
    assert f"its evaluations changed (old_name -> {asked})" in cli(*args).stdout


@pytest.mark.slow
def test_a_job_archived_on_another_machine_is_finished_unless_the_plan_changed(cli, tmp_path, capsys):
    root, archive = tmp_path / "sweeps", tmp_path / "archive"
    args = ["sweep", "--dry-run", "experiment=main", "method=sa", "task=cylinder", *SMOKE, f"sweep_root={root}"]
    cfg = _job_cfg(root, f"archive={archive}")
    now = {stage.name: stage.identity for stage in planned_stages(cfg)}
    sweep_dir = Path(cli(*args).stdout.split(":")[0].removeprefix("sweep "))
    archived = archive / sweep_dir.name / "method=sa,seed=0,task=cylinder" / RESULT
    archived.parent.mkdir(parents=True)
    archived.write_text(json.dumps(_fake_result(cfg, now)))  # its runs are not here: `mapush archive` kept this

    assert "1 jobs, 1 finished; 0 stages to run" in cli(*args, f"archive={archive}").stdout
    assert "0 finished; 2 stages to run; 2 to train" in cli(*args, "archive=null").stdout
    job = sweep_dir / "method=sa,seed=0,task=cylinder"
    job.mkdir(parents=True)  # Hydra makes a job's dir
    assert run_job(cfg, job, 1) == read_result(archived)  # as read today: with its format_version
    assert "archived in" in capsys.readouterr().out
    assert not (root / "stages").exists() and not (job / RESULT).exists()  # nothing trained, nothing written
    # a changed budget is another high-level stage: the archived result does not stand for it
    longer = [*args, f"archive={archive}", "experiment.budgets.smoke.stages.high.env_steps=1600"]
    assert "1 jobs, 0 finished; 2 stages to run; 2 to train" in cli(*longer).stdout


def test_a_job_another_sweep_made_already_is_its_twin_until_an_evaluation_or_curve_differs(tmp_path):
    # the scalability study's 1-robot job is the main table's SA job of the cylinder: the same stages, evaluation
    # and curves at the quick budget, though another method name and experiment
    root, store = tmp_path / "sweeps", tmp_path / "archive"
    main = _job_cfg(root, "budget=quick", "overrides=[]", f"archive={store}")
    scale = compose_config(
        ["experiment=scale", "agents=1", "task=cylinder", "budget=quick", f"sweep_root={root}", f"archive={store}"],
        config_name="sweep",
    )
    now = {stage.name: stage.identity for stage in planned_stages(main)}
    assert {stage.name: stage.identity for stage in planned_stages(scale)} == now
    made = _fake_result(main, now)
    alike = {"episodes": 50, "seeds": [0]}
    made["evals"] = {name: {**record, **alike} for name, record in made["evals"].items()}
    made["curve"] = {"eval": "main", "every_env_steps": 2.0e6, "points": []}
    made["stage_curves"] = {"mid": {"every_env_steps": 2.0e6, "episodes": 200, "seeds": [0], "points": []}}
    donor = store / "main_quick" / "method=sa,seed=0,task=cylinder" / RESULT
    donor.parent.mkdir(parents=True)
    job = root / "scale_quick" / "agents=1,method=ours,seed=0,task=cylinder"

    def twin(record: dict):
        donor.write_text(json.dumps(record))
        return archive.job_made_already(scale, job, planned_stages(scale))

    found, evals, curve = twin(made)
    assert Path(found.job_dir) == donor.parent and sorted(evals) == sorted(scale.experiment.evals)
    assert "path_only" not in evals  # what the study asks for, not all the main job made
    assert curve.eval == "main" and curve.record()["rule"] == OmegaConf.to_container(scale.experiment.budget_rule)
    assert twin({**made, "stage_curves": None}) is None  # the study asks for the mid level's own curve
    assert twin({**made, "curve": None}) is None
    fewer = {**made, "evals": {n: {**e, "episodes": 49} for n, e in made["evals"].items()}}
    assert twin(fewer) is None
    assert twin(_fake_result(main, {**now, "high": "0123456789abcdef"})) is None  # another stage
    # a job is no twin of itself: its own archived result counts only as `archived_result` judges it
    own = store / "scale_quick" / job.name / RESULT
    own.parent.mkdir(parents=True)
    donor.unlink()
    own.write_text(json.dumps(made))
    assert archive.job_made_already(scale, job, planned_stages(scale)) is None


@pytest.mark.slow
def test_a_job_archived_under_another_recipe_is_kept_or_with_rerun_changed_trained_again_superseding_it(
    tmp_path, capsys
):
    base = ["experiment=ocb_ablation", "method=ours", "budget=smoke", "overrides=['debug=smoke']"]
    made = tmp_path / "made" / "sweep"  # the machine that made the job, its runs gone afterwards
    (made / "job").mkdir(parents=True)  # Hydra makes a job's dir
    first = run_job(compose_config([*base, f"sweep_root={made.parent}", "archive=null"], config_name="sweep"),
                    made / "job", 1)  # fmt: skip
    jobs = tmp_path / "jobs"
    archive.archive_results(made.parent, jobs)
    longer = [
        *base,
        f"sweep_root={tmp_path / 'here'}",
        f"archive={jobs}",
        "experiment.budgets.smoke.stages.mid.env_steps=64",
    ]
    job = tmp_path / "here" / "sweep" / "job"
    capsys.readouterr()
    kept = run_job(compose_config(longer, config_name="sweep"), job, 1)
    assert kept.evals == first.evals and not job.exists()  # nothing trained, nothing written
    assert "since its archived result.json; kept (rerun_changed=true runs it again)" in capsys.readouterr().out
    again = run_job(compose_config([*longer, "rerun_changed=true"], config_name="sweep"), job, 1)
    assert read_result(job / SUPERSEDED).evals == first.evals and again.supersedes == SUPERSEDED
    assert identity_of(Path(again.stages["mid"])) != identity_of(Path(first.stages["mid"]))
    assert read_result(job / RESULT) == again


def test_a_job_refuses_code_older_than_the_package_files_and_trains_nothing(tmp_path, monkeypatch):
    # as if every file of mapush had been saved after this process imported it (a sweep's worker, mid-edit)
    monkeypatch.setattr(pipeline, "LOADED_AT", 0.0)
    job = tmp_path / "job"
    job.mkdir()
    with pytest.raises(BadInput, match=r"mapush's code changed after this sweep started \(mapush/\S+\.py, .* more\); "
                       r"valid: the same sweep command again"):  # fmt: skip
        run_job(_job_cfg(tmp_path), job, 1)
    assert not (tmp_path / "stages").exists() and not any(job.iterdir())


def test_result_changes_names_a_changed_budget_and_nothing_for_the_same_plan(tmp_path):
    cfg = _job_cfg(tmp_path)
    result = JobResult(**_fake_result(cfg, {stage.name: stage.identity for stage in planned_stages(cfg)}))
    assert result_changes(result, cfg, planned_stages(cfg)) is None
    longer = _job_cfg(tmp_path, "experiment.budgets.smoke.stages.high.env_steps=1600")
    changes = result_changes(result, longer, planned_stages(longer))
    assert changes.kind == "stages" and changes.stages == ("high",)
    assert str(changes).startswith("its stages changed (high: ") and "mid" not in str(changes)


def test_an_evaluation_that_swapped_rules_before_the_swap_took_the_new_sets_endings_is_stale(tmp_path):
    from mapush.experiments.staleness import still_valid

    cfg = _job_cfg(tmp_path)
    made = _fake_result(cfg, {stage.name: stage.identity for stage in planned_stages(cfg)})
    for name, record in made["evals"].items():
        record["overrides"] = list(stage_plan.eval_overrides(cfg, name))
    swapped = [name for name, record in made["evals"].items() if "rules=strict" in record["overrides"]]
    assert swapped, "the ladder's rungs of mapush's rules evaluate the main jobs under rules=strict"
    change = result_changes(JobResult(**made), cfg, planned_stages(cfg))
    assert change.kind == "evaluation" and change.evaluation in swapped and "swapped its rules" in str(change)
    kept, _ = still_valid(JobResult(**made), cfg, planned_stages(cfg))
    assert set(kept) == set(made["evals"]) - set(swapped)  # the others hold: a rerun evaluates these alone
    for name in swapped:
        made["evals"][name]["config_sha256"] = "a" * 64  # made since: the swap took the new set's endings
    assert result_changes(JobResult(**made), cfg, planned_stages(cfg)) is None


def test_a_result_made_otherwise_than_planned_now_is_told_from_its_job_dir(tmp_path):
    # what `mapush tables` marks: the job is composed again from its dir's axes, experiment, budget and overrides
    cfg = _job_cfg(tmp_path)
    now = {stage.name: stage.identity for stage in planned_stages(cfg)}
    job = {"experiment": "main", "budget": "smoke", "overrides": ["debug=smoke"]}
    job["job_dir"] = str(tmp_path / "main_smoke_debug-smoke" / "method=sa,seed=0,task=cylinder")
    assert made_otherwise(JobResult(**_fake_result(cfg, now) | job)) is None
    earlier = JobResult(**_fake_result(cfg, {**now, "high": "0123456789abcdef"}) | job)  # of another recipe
    assert str(made_otherwise(earlier)) == f"its stages changed (high: 0123456789abcdef -> {now['high']})"
    # another job's axes (the seed) plan other stages than the result's
    other_seed = job | {"job_dir": job["job_dir"].replace("seed=0", "seed=1")}
    assert str(made_otherwise(JobResult(**_fake_result(cfg, now) | other_seed))).startswith("its stages changed (")
    # nothing to tell: stage runs outside a store, or an experiment that no longer composes
    assert made_otherwise(JobResult(**{"stages": {"high": str(tmp_path / "run")}} | job)) is None
    assert made_otherwise(JobResult(**_fake_result(cfg, now) | job | {"experiment": "gone"})) is None


def test_what_tables_found_of_an_archived_job_is_kept_until_something_it_depends_on_changes(tmp_path, monkeypatch):
    cfg = _job_cfg(tmp_path)
    now = {stage.name: stage.identity for stage in planned_stages(cfg)}
    job_dir = tmp_path / "main_smoke_debug-smoke" / "method=sa,seed=0,task=cylinder"
    job_dir.mkdir(parents=True)
    result = _fake_result(cfg, {**now, "high": "0123456789abcdef"})  # archived: no stage run is here
    result |= {"experiment": "main", "budget": "smoke", "overrides": ["debug=smoke"]}
    (job_dir / RESULT).write_text(json.dumps(result))
    memo = tmp_path / "checked.json"
    first = [JobResult(**result, job_dir=str(job_dir))]
    archive.made_otherwise_all(first, memo)
    assert first[0].made_otherwise.stages == ("high",)

    def compose_again(result):
        calls.append(result.job_dir)
        return None

    calls = []
    monkeypatch.setattr(archive, "made_otherwise", compose_again)
    again = [JobResult(**result, job_dir=str(job_dir))]
    archive.made_otherwise_all(again, memo)
    assert calls == [] and again[0].made_otherwise == first[0].made_otherwise  # found in the memo, alike
    (job_dir / RESULT).write_text(json.dumps(result | {"budget": "quick"}))  # the result changed: checked again
    archive.made_otherwise_all(again, memo)
    assert calls == [str(job_dir)] and again[0].made_otherwise is None
    record = stages.stage_dir(tmp_path, now["high"]) / stages.IDENTITY_FILE  # a stage record appears: again
    record.parent.mkdir(parents=True)
    record.write_text("identity: x\n")
    archive.made_otherwise_all(again, memo)
    assert calls == [str(job_dir)] * 2


def test_what_tables_found_of_a_job_whose_runs_are_here_is_kept_until_a_runs_config_changes(tmp_path, monkeypatch):
    cfg = _job_cfg(tmp_path)
    now = {stage.name: stage.identity for stage in planned_stages(cfg)}
    job_dir = tmp_path / "main_smoke_debug-smoke" / "method=sa,seed=0,task=cylinder"
    job_dir.mkdir(parents=True)
    result = _fake_result(cfg, now) | {"experiment": "main", "budget": "smoke", "overrides": ["debug=smoke"]}
    (job_dir / RESULT).write_text(json.dumps(result))
    run_config = Path(result["stages"]["high"]) / "config.yaml"
    run_config.parent.mkdir(parents=True)
    run_config.write_text("level: {name: high}\n")
    memo, calls = tmp_path / "checked.json", []
    monkeypatch.setattr(archive, "made_otherwise", lambda r: calls.append(r.job_dir))
    archive.made_otherwise_all([JobResult(**result, job_dir=str(job_dir))], memo)
    archive.made_otherwise_all([JobResult(**result, job_dir=str(job_dir))], memo)
    assert calls == [str(job_dir)]  # checked once, then found in the memo
    run_config.write_text("level: {name: high}\nlowlevel: {name: go1}\n")  # what its evaluations read changed
    archive.made_otherwise_all([JobResult(**result, job_dir=str(job_dir))], memo)
    assert calls == [str(job_dir)] * 2
    run_config.unlink()  # the run gone (an archive's copy elsewhere): a finding of its own, then both are kept
    archive.made_otherwise_all([JobResult(**result, job_dir=str(job_dir))], memo)
    assert calls == [str(job_dir)] * 3 and len(json.loads(memo.read_text())["/".join(job_dir.parts[-2:])]) == 2
    run_config.write_text("level: {name: high}\nlowlevel: {name: go1}\n")
    archive.made_otherwise_all([JobResult(**result, job_dir=str(job_dir))], memo)
    assert calls == [str(job_dir)] * 3


@pytest.mark.slow
def test_a_job_whose_budget_changed_is_kept_or_with_rerun_changed_trained_again(tmp_path, capsys):
    base = ["experiment=ocb_ablation", "method=ours", "budget=smoke", "overrides=['debug=smoke']"]
    base.append(f"sweep_root={tmp_path}")
    job = tmp_path / "job"
    job.mkdir()  # Hydra makes a job's dir
    first = run_job(compose_config(base, config_name="sweep"), job, 1)
    longer = [*base, "experiment.budgets.smoke.stages.mid.env_steps=64"]  # 2 iterations instead of 1
    capsys.readouterr()
    assert run_job(compose_config(longer, config_name="sweep"), job, 1) == first
    assert "kept (rerun_changed=true runs it again)" in capsys.readouterr().out
    again_cfg = compose_config([*longer, "rerun_changed=true"], config_name="sweep")
    again = run_job(again_cfg, job, 1)
    assert read_result(job / SUPERSEDED) == first
    assert identity_of(Path(again.stages["mid"])) == planned_stages(again_cfg)[0].identity
    assert identity_of(Path(again.stages["mid"])) != identity_of(Path(first.stages["mid"]))
    assert result_changes(again, again_cfg, planned_stages(again_cfg)) is None
    # an evaluation that changed is made again; what still holds (the other evaluation, the curve) is kept
    shorter = compose_config([*longer, "rerun_changed=true", "experiment.evals.t40=['level.episode_length_s=30']"],
                             config_name="sweep")  # fmt: skip
    change = result_changes(again, shorter, planned_stages(shorter))
    assert (change.kind, change.evaluation) == ("evaluation", "t40")
    assert str(change) == (
        "evaluation 't40' changed (level.episode_length_s=40 level.episode_length_s=1 -> "
        "level.episode_length_s=30 level.episode_length_s=1)"  # each with the smoke budget's 1 s episodes after it
    )
    assert change.concerns(again, "t40") and not change.concerns(again, "t20")
    checkpoints = sorted(Path(again.stages["mid"]).glob("model_*.pt"))
    third = run_job(shorter, job, 1)
    assert third.evals["t20"] == again.evals["t20"] and third.curve == again.curve
    assert third.evals["t40"].overrides == ["level.episode_length_s=30", "level.episode_length_s=1"]
    assert sorted(Path(third.stages["mid"]).glob("model_*.pt")) == checkpoints  # nothing trained
    assert third.supersedes == SUPERSEDED and read_result(job / SUPERSEDED) == again
    # a legged evaluation names the locomotion policy that walked its robots; another one makes it stale
    legged = compose_config(
        [*longer, "rerun_changed=true", "experiment.evals.t40=['level.episode_length_s=30','lowlevel=go1']"],
        config_name="sweep",
    )
    fourth = run_job(legged, job, 1)
    walker = fourth.evals["t40"].lowlevel_policy
    shipped = Path(walker["file"])
    assert shipped.name == "policy.pt" and walker["sha256"] == hashlib.sha256(shipped.read_bytes()).hexdigest()[:16]
    assert fourth.evals["t20"].lowlevel_policy is None  # the tracker has no policy
    assert result_changes(fourth, legged, planned_stages(legged)) is None
    gone = {name: str(tmp_path / "gone" / Path(path).relative_to(tmp_path)) for name, path in fourth.stages.items()}
    elsewhere = dataclasses.replace(fourth, stages=gone)  # the same stages' runs, on a machine that is not this one
    elsewhere.evals = {**fourth.evals, "t40": dataclasses.replace(fourth.evals["t40"])}
    elsewhere.evals["t40"].lowlevel_policy = {**walker, "file": "/another/checkout/policy.pt"}
    assert result_changes(elsewhere, legged, planned_stages(legged)) is None  # the same policy in another checkout
    fourth.evals["t40"].lowlevel_policy["sha256"] = "0" * 16  # as if the shipped policy had been replaced
    stale = "evaluation 't40' walked its robots with another locomotion policy than now"
    assert str(result_changes(fourth, legged, planned_stages(legged))) == stale
    elsewhere.evals["t40"].lowlevel_policy["sha256"] = "0" * 16  # and its runs gone: the plan says which
    assert str(result_changes(elsewhere, legged, planned_stages(legged))) == stale


@pytest.mark.slow
def test_the_dry_run_estimates_training_time_from_finished_stages_of_the_same_shape(cli, tmp_path):
    root, archive = tmp_path / "sweeps", tmp_path / "archive"
    # SA's cylinder mid level of seed 1 finished on another machine in 3600 core-seconds (32 env-steps at the smoke
    # budget) and was archived with its stage.yaml; its high level left no time
    other = _job_cfg(root, "seed=1")
    mid, high = planned_stages(other)
    job = archive / "elsewhere_smoke" / "method=sa,seed=1,task=cylinder"
    job.mkdir(parents=True)
    runs = {
        name: str(root / "stages" / s.identity / name / "cylinder" / "run")
        for name, s in (("mid", mid), ("high", high))
    }
    (job / RESULT).write_text(json.dumps({"stages": runs, "stage_core_s": {"mid": 3600.0}, "evals": {}}))
    config = compose_stage(mid.overrides, lambda cfg: mid.iterations)
    record = archive / "stages" / mid.identity / "stage.yaml"
    record.parent.mkdir(parents=True)
    record.write_text(OmegaConf.to_yaml({"identity": mid.identity, "config": config}))

    args = ["sweep", "--dry-run", "experiment=main", "method=sa", "task=cylinder", *SMOKE, f"sweep_root={root}"]
    plan = cli(*args, f"archive={archive}")
    assert plan.returncode == 0, plan.stderr
    # seed 0's mid level has seed 1's shape: 3600 core-seconds for as many env-steps; its high level has no like
    rows = [line for line in plan.stdout.splitlines() if "method=sa,seed=0" in line]
    assert rows[0].split()[1] == "mid" and rows[0].endswith("~1.00 core-h")
    assert rows[1].split()[1] == "high" and rows[1].endswith("no measured stage like it")
    assert "1.0 core-hours for 1 of the 2 stages to train (1 not estimated: no measured stage like them)" in plan.stdout
    # twice the env-steps, twice the time
    longer = cli(*args, f"archive={archive}", "experiment.budgets.smoke.stages.mid.env_steps=64")
    assert "~2.00 core-h" in longer.stdout
    # seed 2's like stage took three times as long per env-step (another machine, another day): a range
    third = planned_stages(_job_cfg(root, "seed=2"))[0]
    job = archive / "elsewhere_smoke" / "method=sa,seed=2,task=cylinder"
    job.mkdir(parents=True)
    runs = {"mid": str(root / "stages" / third.identity / "mid" / "cylinder" / "run")}
    (job / RESULT).write_text(json.dumps({"stages": runs, "stage_core_s": {"mid": 10800.0}, "evals": {}}))
    record = archive / "stages" / third.identity / "stage.yaml"
    record.parent.mkdir(parents=True)
    config = compose_stage(third.overrides, lambda cfg: third.iterations)
    record.write_text(OmegaConf.to_yaml({"identity": third.identity, "config": config}))
    ranged = cli(*args, f"archive={archive}")
    rows = [line for line in ranged.stdout.splitlines() if "method=sa,seed=0" in line]
    assert rows[0].endswith("~1.00-3.00 core-h") and "per env-step they took): 1.0-3.0 core-hours" in ranged.stdout
    assert "training time: not estimated" in cli(*args, "archive=null").stdout


def test_a_curve_for_a_stage_no_method_has_is_refused_with_the_valid_ones(tmp_path):
    cfg = _job_cfg(tmp_path, "+experiment.budgets.smoke.curve.stages.midd={}")
    with pytest.raises(BadInput, match=r"curve stage 'midd'; valid: .*high.*mid"):
        planned_stages(cfg)
