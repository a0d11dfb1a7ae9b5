"""Learning curves in the tables: env-steps to a success rate, the budget rule, the paper's OCB finding checked,
the curves plot; from fixture job results with hand-made curves."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from pathlib import Path

import numpy as np
import pytest

from mapush.eval.curve_points import tail_gain
from mapush.experiments.job_physics import ObjectPhysics
from mapush.experiments.results import RESULT, Change, JobResult
from mapush.report.formats import OTHERWISE_NOTE, Cell, Table, csv_text, keys, latex, markdown, pick, sidecar

RULE = {"tail": 0.2, "max_gain": 0.03}
RANGED = ObjectPhysics(mass_kg=4.0, friction=(0.2, 0.4), mass_range_kg=(2.0, 64.0), robot_capacity_n=50.0)
"""A team-study job's object as its sweep records it: drawn over 2-64 kg in training."""


def physics_of(overrides) -> ObjectPhysics:
    """The physics a team job made with `overrides` records: one mass where they set it and turn the range off."""
    if "task.object.mass_range=null" not in overrides:
        return RANGED
    mass = next(float(o.partition("=")[2]) for o in overrides if o.startswith("task.object.mass="))
    return ObjectPhysics(mass_kg=mass, friction=RANGED.friction, robot_capacity_n=RANGED.robot_capacity_n)


CURVES = {  # success at 1, 2, 3, 4, 5 M env-steps, per seed
    "ours": [[0.2, 0.5, 0.6, 0.7, 0.71], [0.3, 0.4, 0.55, 0.66, 0.68], [0.1, 0.2, 0.3, 0.6, 0.63]],
    "ours_no_ocb": [[0.1, 0.2, 0.3, 0.4, 0.45], [0.1, 0.3, 0.5, 0.5, 0.5], [0.0, 0.1, 0.1, 0.2, 0.3]],
}
FINAL_T20 = {"ours": [0.6, 0.7, 0.8], "ours_no_ocb": [0.4, 0.5, 0.3]}


def _write(root: Path, method: str, seed: int) -> None:
    job = root / "ocb_ablation_quick" / f"method={method},seed={seed}"
    job.mkdir(parents=True)
    points = [
        {"iteration": k, "env_steps": (k + 1) * 1_000_000, "success_rate": sr, "success_rate_std": 0.0}
        for k, sr in enumerate(CURVES[method][seed])
    ]
    sr = FINAL_T20[method][seed]
    result = {
        "table": "ocb_ablation",
        "variant": "quick",
        "method": method,
        "task": "ocb_cuboid",
        "num_agents": 2,
        "seed": seed,
        "evals": {
            "t20": {"success_rate": sr, "completion_time": 0.8, "completion_time_s": 16.0},
            "t40": {"success_rate": sr, "completion_time": 0.6, "completion_time_s": 24.0},
        },
        "curve": {"eval": "t20", "every_env_steps": 1e6, "reach": 0.5, "rule": RULE, "points": points},
    }
    (job / RESULT).write_text(json.dumps(result))


@pytest.fixture
def curve_runs(tmp_path) -> Path:
    for method in CURVES:
        for seed in range(3):
            _write(tmp_path / "runs", method, seed)
    return tmp_path / "runs"


def test_tail_gain_is_the_success_added_over_the_last_fifth():
    points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": sr} for k, sr in enumerate([0.2, 0.5, 0.6, 0.7, 0.74])]
    assert tail_gain(points, 0.2) == pytest.approx(0.04)  # 5M: 0.74, at or before 4M: 0.70
    assert tail_gain(points, 0.5) == pytest.approx(0.24)  # at or before 2.5M: 0.50
    assert tail_gain(points[:1], 0.2) is None


def test_steps_to_reach_goes_on_as_the_last_stretch_of_the_curve_went():
    from mapush.eval.curve_points import steps_to_reach

    rates = [0.1, 0.1, 0.2, 0.25, 0.3]
    points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": sr} for k, sr in enumerate(rates)]
    # the last fifth: 4M at 0.25 to 5M at 0.30, 0.05 a million; 0.5 is 0.2 away: 4M more
    assert steps_to_reach(points, 0.5, 0.2) == pytest.approx(9_000_000)
    assert steps_to_reach(points, 0.3, 0.2) == 5_000_000  # reached at the last point
    flat = [{**p, "success_rate": 0.3} for p in points]
    assert steps_to_reach(flat, 0.5, 0.2) is None and steps_to_reach(points[:1], 0.5, 0.2) is None


def test_a_budget_past_its_peak_is_called_falling_with_the_peak_of_the_mean_curve():
    from mapush.report.curve_findings import budget_verdict

    def result(rates):
        points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": sr} for k, sr in enumerate(rates)]
        return JobResult(curve={"rule": RULE, "points": points})

    # last fifth: 0.80 -> 0.70 and 0.90 -> 0.86: -7.0 +- 3.0 points; mean curve 0.65, 0.9, 0.85, 0.85, 0.78
    falling = [result([0.6, 0.9, 0.8, 0.8, 0.7]), result([0.7, 0.9, 0.9, 0.9, 0.86])]
    verdict = budget_verdict("Ours", falling)
    assert verdict.holds is True  # it has done its work: the rule holds
    assert verdict.numbers == pytest.approx({"tail_gain_points": -7.0, "tail_gain_std": 3.0, "limit_points": 3.0,
                                             "peak_sr": 90.0, "peak_env_steps": 2_000_000})  # fmt: skip
    # a loss smaller than the rule's 3 points is flat, not falling: no peak to name
    flat = budget_verdict("Ours", [result([0.6, 0.9, 0.8, 0.8, 0.78])])
    assert flat.holds is True and "peak_sr" not in flat.numbers


def test_a_gain_on_the_rules_bound_is_judged_as_printed_not_by_its_float32_noise():
    import numpy as np

    from mapush.report.curve_findings import budget_verdict

    def result(rates):  # the rates as result.json holds them: float32 means
        points = [{"env_steps": (k + 1) * 1e6, "success_rate": float(np.float32(sr))} for k, sr in enumerate(rates)]
        return JobResult(curve={"rule": RULE, "points": points})

    # 0.49 -> 0.52 and 0.36 -> 0.39: +3.0 points, the rule's bound (< 3); in float32 each is +2.9999997
    on_bound = [result([0.1, 0.2, 0.3, 0.49, 0.52]), result([0.1, 0.2, 0.3, 0.36, 0.39])]
    bound = budget_verdict("SA", on_bound)
    assert bound.holds is False and bound.numbers["tail_gain_points"] == 3.0  # still learning
    # 0.52 -> 0.49 on both: -3.0, the bound of "falling"; and a gain of 0 is +0.0, never -0.0
    assert "peak_sr" in budget_verdict("SA", [result([0.1, 0.2, 0.3, 0.52, 0.49])] * 2).numbers
    zero = budget_verdict("SA", [result([0.1, 0.2, 0.3, 0.57, 0.57])] * 2).numbers["tail_gain_points"]
    assert zero == 0.0 and np.copysign(1.0, zero) == 1.0


def test_a_curve_that_stays_at_0_did_not_learn_and_is_not_called_flattened():
    from mapush.report.curve_findings import budget_verdict

    def result(rates):
        points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": sr} for k, sr in enumerate(rates)]
        return JobResult(curve={"rule": RULE, "points": points})

    never = budget_verdict("H+L", [result([0.0] * 5), result([0.0] * 5)])
    assert never.holds is False and never.numbers == {"checkpoints": 10}  # 0 % at every evaluated checkpoint
    once = budget_verdict("H+L", [result([0.0, 0.0, 0.02, 0.0, 0.0])])  # one success once: it did learn a little
    assert once.holds is True and "checkpoints" not in once.numbers and "tail_gain_points" in once.numbers


def test_a_seed_whose_curve_stays_at_0_is_named_beside_the_mean_of_those_that_learned():
    from mapush.report.curve_findings import budget_verdict

    def result(seed, rates):
        points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": sr} for k, sr in enumerate(rates)]
        return JobResult(seed=seed, curve={"rule": RULE, "points": points})

    learned, never = result(0, [0.0, 0.2, 0.4, 0.5, 0.6]), result(1, [0.0] * 5)
    verdict = budget_verdict("H+L FT", [learned, never])
    assert verdict.holds is False and verdict.numbers["seeds_not_learned"] == 1  # still learning, one seed never
    assert "seeds_not_learned" not in budget_verdict("H+L FT", [learned, result(1, [0.0, 0.1, 0.2, 0.3, 0.4])]).numbers


def test_the_ocb_table_has_env_steps_to_50_percent_findings_and_curves(cli, tmp_path, curve_runs):
    proc = cli("tables", "--runs", curve_runs, "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    md = (tmp_path / "out" / "ocb_ablation_quick.md").read_text()
    assert "Env-steps (M) to 50 % S.R., timeout 20 s" in md
    # ours reaches 50 % at 2, 3 and 4 M -> 3.00 +- 0.82; without OCB only seed 1 does, at 3 M
    assert "| 3.00 \u00b1 0.82 |" in md
    assert "| 3.00 (1 seed) (2 of 3 seeds never) |" in md
    side = json.loads((tmp_path / "out" / "ocb_ablation_quick.json").read_text())
    found = {(f["key"], f["about"]): f for f in side["findings"]}
    # final S.R. at 20 s: 70.0 +- 8.2 against 40.0 +- 8.2: a gap of 30 points, spread hypot(8.16, 8.16) = 11.5
    gain = found["ocb_sr_gain", "timeout 20 s"]
    assert gain["holds"] is True and gain["numbers"] == pytest.approx(
        {"left": 70.0, "right": 40.0, "spread": 11.547}, abs=1e-3
    )
    # C.T. 16 s in both arms: no saving, against the paper's 14.9 vs 18.3 s
    saving = found["ocb_ct_saving", "timeout 20 s"]
    assert saving["holds"] is False and saving["numbers"] == pytest.approx({"left": 16.0, "right": 16.0, "spread": 0.0})
    reach = found["reading", "Env-steps (M) to 50 % S.R., timeout 20 s"]  # a reading: the paper measured none
    assert reach["holds"] is None and reach["numbers"] == pytest.approx({"Ours": 3.0, "Ours w/o OCB": 3.0})
    # last fifth: ours gains 1, 2, 3 points -> +2.0 +- 0.8; without OCB 5, 0, 10 -> +5.0 +- 4.1
    ours, without = found["budget", "Ours"], found["budget", "Ours w/o OCB"]
    assert ours["holds"] is True and ours["numbers"]["tail_gain_points"] == pytest.approx(2.0)
    assert without["holds"] is False and without["numbers"]["tail_gain_points"] == pytest.approx(5.0)
    reach = [c for c in side["cells"] if c["column"].startswith("Env-steps")]
    assert [(c["seeds"], c["unreached"], len(c["sources"])) for c in reach] == [(3, 0, 3), (1, 2, 1)]
    assert (tmp_path / "out" / "ocb_ablation_quick_curves.png").stat().st_size > 1000


@pytest.mark.slow
def test_tables_can_write_one_table_and_refuse_an_unknown_one(cli, tmp_path, curve_runs):
    proc = cli("tables", "--runs", curve_runs, "--out", tmp_path / "out", "--table", "ocb_ablation")
    assert proc.returncode == 0, proc.stderr
    written = [f"ocb_ablation_quick{ext}" for ext in (".csv", ".json", ".md", ".tex", "_curves.png")]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == written
    assert (curve_runs / "jobs_checked.json").is_file()  # the memo, with the results it speaks of
    proc = cli("tables", "--runs", curve_runs, "--out", tmp_path / "other", "--table", "table9")
    valid = "valid: ladder, main, ocb_ablation, scale, solo_team, team"
    assert proc.returncode == 2 and "'table9'" in proc.stderr and valid in proc.stderr
    assert not (tmp_path / "other").exists()


def test_the_main_tables_findings_from_hand_made_results():
    from mapush.report.main_table import PAPER, _main_findings

    cuboid = ObjectPhysics(mass_kg=4.0, friction=(0.3, 0.35), robot_capacity_n=12.5)  # moved where it slides easily

    def job(method, seed, evals):
        ev = {k: {"success_rate": sr, "completion_time": ct, "timeout_s": 160.0} for k, (sr, ct) in evals.items()}
        return JobResult(method=method, task="cuboid", seed=seed, evals=ev, job_dir=f"{method}{seed}", physics=cuboid)

    results = [
        job("ours", 0, {"main": (0.80, 0.50), "path_only": (0.90, 0.45), "go1": (0.75, 0.6)}),
        job("ours", 1, {"main": (0.70, 0.60), "path_only": (0.70, 0.60), "go1": (0.55, 0.7)}),
        job("sa", 0, {"main": (0.10, 0.90), "go1": (0.40, 0.8)}),
        job("sa", 1, {"main": (0.20, 0.90), "go1": (0.90, 0.4)}),
        job("ml", 0, {"main": (0.80, 0.90)}),
        job("hl", 0, {"main": (0.0, 1.0), "path_only": (0.45, 0.80)}),  # the hand-written pusher: 45 %
        job("hl_ft", 0, {"main": (0.50, 0.70)}),
    ]
    found = _main_findings(results, PAPER["main"], "cuboid")
    assert keys(found) == [(key, "Cuboid") for key in ("ours_vs_paper", "success_time", "ours_above_baselines",
                           "sa_below_ours", "hl_vs_pusher", "hl_ft_vs_pusher", "high_level_vs_path", "legged_gap",
                           "legged_vs_paper", "legged_sa_below_ours")]  # fmt: skip
    # Ours: S.R. (80 + 70) / 2 = 75.0 < 77.5, C.T. (0.5 + 0.6) / 2 = 0.55 <= 0.66: the paper's claim fails on S.R.
    paper = pick(found, "ours_vs_paper", "Cuboid")
    assert paper.holds is False
    assert paper.numbers == pytest.approx({"ours_sr": 75.0, "paper_sr": 77.5, "ours_ct": 0.55, "paper_ct": 0.66})
    # successes alone: (0.55 - 0.25) / 0.75 x 160 s = 64 s; the paper's (0.66 - 0.225) / 0.775 x 160 s = 89.8 s
    fast = pick(found, "success_time", "Cuboid")
    assert fast.holds is None  # a reading, no claim
    assert fast.numbers == pytest.approx({"ours_success_s": 64.0, "paper_success_s": 89.8}, abs=0.1)
    # the paper's claim that Ours beats every baseline: M+L (80 %) is at or above
    baselines = pick(found, "ours_above_baselines", "Cuboid")
    assert baselines.holds is False and baselines.numbers["M+L"] == pytest.approx(80.0)
    # SA (10 + 20) / 2 = 15 % below Ours, beside the drag (4 kg x 9.81 x the friction 0.3-0.35: 11.8-13.7 N)
    assert pick(found, "sa_below_ours", "Cuboid").holds is True
    assert pick(found, "sa_below_ours", "Cuboid").numbers == pytest.approx(
        {"sa_sr": 15.0, "ours_sr": 75.0, "drag_low_n": 11.77, "drag_high_n": 13.73, "capacity_n": 12.5}, abs=0.01
    )
    # H+L 0 % and H+L FT 50 % against the hand-written pusher's 45 %
    learners = [pick(found, f"{m}_vs_pusher", "Cuboid") for m in ("hl", "hl_ft")]
    assert [(f.holds, f.numbers["learned_sr"], f.numbers["pusher_sr"]) for f in learners] == [
        (False, 0.0, 45.0), (True, 50.0, 45.0)]  # fmt: skip
    path = pick(found, "high_level_vs_path", "Cuboid")
    assert path.holds is False and path.numbers["gap_points"] == pytest.approx(-5.0)  # 75 - 80: path only
    legged = pick(found, "legged_gap", "Cuboid")
    assert legged.holds is True and legged.numbers["gap_points"] == pytest.approx(10.0)  # 75 - 65 on Go1s
    # Ours on legs (75 + 55) / 2 = 65.0 against the paper's 77.5; these records count no events: no fall share
    on_legs = pick(found, "legged_vs_paper", "Cuboid")
    assert on_legs.holds is False and on_legs.numbers == pytest.approx({"legged_sr": 65.0, "paper_sr": 77.5})
    # SA on legs: (40 + 90) / 2 = 65.0, not below Ours' (75 + 55) / 2 = 65.0; M+L has no legged evaluation
    sa_legged = pick(found, "legged_sa_below_ours", "Cuboid")
    assert sa_legged.holds is False and sa_legged.numbers == pytest.approx({"baseline_sr": 65.0, "ours_sr": 65.0})
    results[3].evals["go1"].success_rate = 0.80  # (40 + 80) / 2 = 60.0
    assert pick(_main_findings(results, PAPER["main"], "cuboid"), "legged_sa_below_ours", "Cuboid").holds is True
    assert _main_findings(results, PAPER["main"], "tblock") == []


def test_ours_on_legs_below_the_paper_says_how_often_a_robot_fell_on_go1s_and_on_trackers():
    from mapush.report.main_table import PAPER, _main_findings

    def evaluation(sr, fell):
        return {"success_rate": sr, "completion_time": 0.9, "timeout_s": 160.0,
                "events": {"falls": {"episode_share": fell, "per_episode": fell}}}  # fmt: skip

    results = [JobResult(method="ours", task="cylinder", seed=seed, job_dir=f"ours{seed}",
                         evals={"main": evaluation(0.5, tracker), "go1": evaluation(sr, legged)})
               for seed, sr, legged, tracker in ((0, 0.1, 0.9, 0.5), (1, 0.2, 0.7, 0.3))]  # fmt: skip
    line = pick(_main_findings(results, PAPER["main"], "cylinder"), "legged_vs_paper", "Cylinder")
    # (10 + 20) / 2 = 15.0 % against 71.2 %; falls (90 + 70) / 2 = 80 % on Go1s, (50 + 30) / 2 = 40 % on trackers
    assert line.holds is False
    assert line.numbers == pytest.approx(
        {"legged_sr": 15.0, "paper_sr": 71.2, "legged_fall_pct": 80.0, "tracker_fall_pct": 40.0}
    )
    assert "a robot fell in 80 % of its episodes on Go1s, on trackers 40 % (mean over 2 seeds)" in line.text


def test_a_baseline_below_the_pusher_with_a_rising_curve_says_how_many_env_steps_it_would_need():
    from mapush.report.main_table import PAPER, _main_findings

    def job(method, seed, sr, rates=None):
        points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": r} for k, r in enumerate(rates or [])]
        curve = {"rule": RULE, "points": points} if rates else None
        ev = {"main": {"success_rate": sr, "completion_time": 0.9, "timeout_s": 160.0}}
        if method == "hl":
            ev["path_only"] = {"success_rate": 0.45, "completion_time": 0.8, "timeout_s": 160.0}
        return JobResult(method=method, task="cuboid", seed=seed, evals=ev, curve=curve, job_dir=f"{method}{seed}")

    # two seeds, mean curve 0.05, 0.1, 0.15, 0.2, 0.25: +0.05 over the last fifth (4M to 5M); 0.45 is 0.2 away
    rising = [job("hl_ft", 0, 0.2, [0.0, 0.1, 0.1, 0.2, 0.2]), job("hl_ft", 1, 0.3, [0.1, 0.1, 0.2, 0.2, 0.3])]
    flat = [job("hl", 0, 0.1, [0.1] * 5)]
    found = _main_findings([job("ours", 0, 0.8), *rising, *flat], PAPER["main"], "cuboid")
    hl, hl_ft = (pick(found, f"{m}_vs_pusher", "Cuboid") for m in ("hl", "hl_ft"))
    assert hl_ft.holds is False and hl_ft.numbers == pytest.approx(
        {"learned_sr": 25.0, "pusher_sr": 45.0, "env_steps_to_pusher": 9_000_000}
    )
    assert hl.holds is False and hl.numbers["env_steps_to_pusher"] is None  # a flat curve never reaches it


def test_the_legged_finding_names_the_exceptions_that_ended_its_episodes():
    from mapush.report.main_table import PAPER, _main_findings

    def job(seed, go1_sr, robot_tilt, collision):
        go1 = {
            "success_rate": go1_sr,
            "completion_time": 0.7,
            "exceptions": {"robot_collision": collision, "robot_tilt": robot_tilt, "diverged": 0.0},
        }
        main = {"success_rate": 0.8, "completion_time": 0.5}
        return JobResult(method="ours", task="cuboid", seed=seed, evals={"main": main, "go1": go1},
                         job_dir=f"ours{seed}")  # fmt: skip

    found = _main_findings([job(0, 0.5, 0.40, 0.02), job(1, 0.4, 0.30, 0.0)], PAPER["main"], "cuboid")
    # 80 - 45 = 35 points; robot_tilt (40 + 30) / 2 = 35 %, robot_collision (2 + 0) / 2 = 1 %, diverged left out
    legged = pick(found, "legged_gap", "Cuboid")
    assert legged.holds is False and legged.numbers == pytest.approx(
        {"gap_points": 35.0, "ended_by robot_tilt": 35.0, "ended_by robot_collision": 1.0}
    )


def test_each_object_says_what_ended_each_method_s_episodes():
    from mapush.report.main_table import PAPER, _main_findings

    def job(method, seed, **exceptions):
        kinds = {"robot_collision": 0.0, "robot_tilt": 0.0, "diverged": 0.0} | exceptions
        main = {"success_rate": 0.5, "completion_time": 0.7, "exceptions": kinds}
        return JobResult(method=method, task="cuboid", seed=seed, evals={"main": main}, job_dir=f"{method}{seed}")

    jobs = [job("ours", 0, robot_tilt=0.1), job("ours", 1, robot_tilt=0.3, robot_collision=0.04),
            job("ml", 0, robot_collision=0.5), job("sa", 0)]  # fmt: skip
    last = pick(_main_findings(jobs, PAPER["main"], "cuboid"), "ended_by", "Cuboid")
    # Ours: tilt (10 + 30) / 2 = 20 %, collision (0 + 4) / 2 = 2 %; M+L collision 50 %; SA none; H+L no job
    assert last.holds is None and last.numbers == pytest.approx(
        {"M+L robot_collision": 50.0, "Ours robot_tilt": 20.0, "Ours robot_collision": 2.0}
    )
    jobs[0].made_otherwise = Change("stages", "its stages changed", ("mid",))  # one of Ours' jobs: made otherwise
    marked = pick(_main_findings(jobs, PAPER["main"], "cuboid"), "ended_by", "Cuboid")
    assert marked.numbers["Ours \u2020 robot_tilt"] == pytest.approx(20.0)


def scale_jobs(made: dict) -> list[JobResult]:
    """Scalability jobs by robot count: (hierarchy S.R. per seed, C.T., the mid level's own curve's end per seed)."""

    def own_curve(end: float) -> dict:  # the mid level alone: the last point of its own curve is its figure
        return {"mid": {"points": [{"success_rate": 0.05}, {"success_rate": end}]}}

    return [
        JobResult(job_dir=f"agents={n},seed={seed}", table="scale", variant="quick", num_agents=n, seed=seed,
                  evals={"main": {"success_rate": sr[seed], "completion_time": ct}}, stage_curves=own_curve(mid[seed]))
        for n, (sr, ct, mid) in made.items() for seed in range(len(sr))
    ]  # fmt: skip


def test_the_reference_mid_finding_weighs_the_gap_against_the_seeds_spread():
    from mapush.report.tables import BUILDERS

    def reference(mid: tuple[float, float]):  # the 3-robot row's mid level, against the original's 72.3 %
        return BUILDERS["scale"](scale_jobs({3: ((0.5, 0.5), 0.5, mid)}), "quick").finding("reference_mid", "3 robots")

    # 61 +- 1 is 11.3 points below 72.3: beyond the spread; 80 +- 2 at or above; 71 +- 3 within it
    below, above, within = (reference(mid) for mid in ((0.60, 0.62), (0.78, 0.82), (0.68, 0.74)))
    assert below.holds is False
    assert above.holds is True and above.numbers == pytest.approx({"left": 80.0, "right": 72.3, "spread": 2.0})
    assert within.holds is None and within.numbers["left"] == pytest.approx(71.0)  # no claim either way
    nothing = BUILDERS["scale"](scale_jobs({1: ((0.5, 0.5), 0.5, (0.5, 0.5))}), "quick")
    assert nothing.finding("reference_mid", "3 robots").holds is None  # no 3-robot job: not measured


def test_cells_from_jobs_made_otherwise_are_marked_and_the_jobs_listed():
    cell = Cell([80.0, 60.0], ["a", "b"], paper=(77.5, 3.0), otherwise=1)
    assert cell.text() == "70.0 \u00b1 10.0 \u2020 (77.5 \u00b1 3.0)" and cell.record()["made_otherwise"] == 1
    # the paper's numbers as it gives them, never rounded to our cell's digits
    assert Cell([0.0, 0.0], paper=(0.23, 0.02)).text() == "0.0 \u00b1 0.0 (0.23 \u00b1 0.02)"
    assert Cell([0.5, 0.7], paper=(1.0, 0.0), digits=2).text() == "0.60 \u00b1 0.10 (1.00 \u00b1 0.00)"
    assert "\u2020" not in Cell([80.0, 60.0], ["a", "b"]).text()
    table = Table("t", "T", ["Task"], ["S.R."], [(["Cuboid"], [cell])], otherwise=["job: its stages changed (...)"])
    lines = markdown(table).splitlines()
    assert lines[lines.index(OTHERWISE_NOTE) + 1] == "- job: its stages changed (...)"
    assert "$\\dagger$" in latex(table) and sidecar(table)["made_otherwise"] == ["job: its stages changed (...)"]
    # the CSV keeps what the Markdown shows beside the numbers: the mark, seeds that never reached, the note
    rows = list(csv.DictReader(io.StringIO(csv_text(table))))
    assert rows[0]["made_otherwise"] == "1" and rows[0]["mean"] == "70.0" and rows[0]["paper_mean"] == "77.5"
    # each seed's value beside the job it came from, in the CSV and the sidecar alike
    assert (rows[0]["values"], rows[0]["sources"]) == ("80.0;60.0", "a;b")
    assert sidecar(table)["cells"][0]["values"] == [80.0, 60.0]
    odd = Table("t", "T", ["Task"], ["M"], [(["Cuboid"], [Cell([8.412345678], unreached=2, note="margin 0.5")])])
    assert {
        k: v for k, v in next(csv.DictReader(io.StringIO(csv_text(odd)))).items() if k in ("mean", "unreached", "note")
    } == {"mean": "8.41235", "unreached": "2", "note": "margin 0.5"}
    assert OTHERWISE_NOTE not in markdown(Table("t", "T", ["Task"], ["S.R."], [(["Cuboid"], [Cell([1.0])])]))


def test_a_job_with_one_stale_evaluation_or_stage_marks_only_the_cells_made_of_it():
    from mapush.experiments.results import Change
    from mapush.report.cells import collect as _collect

    def job(name: str, change: Change) -> JobResult:
        stages = {"mid": "stages/m1/mid/run", "high": "stages/h1/high/run"}
        evals = {
            "main": {"success_rate": 0.8, "checkpoint": "stages/h1/high/run/model_48.pt"},
            "go1": {"success_rate": 0.5, "checkpoint": "stages/h1/high/run/model_48.pt"},
            "mid": {"success_rate": 0.7, "checkpoint": "stages/m1/mid/run/model_999.pt"},
        }
        return JobResult(job_dir=name, method="ours", stages=stages, evals=evals, made_otherwise=change)

    def marked(result: JobResult) -> set[str]:
        return {name for name in result.evals if _collect([result], "success_rate", 100.0, eval=name).otherwise}

    assert marked(job("a", Change("evaluation", "walked another way", evaluation="go1"))) == {"go1"}
    # the high level retrained on the same mid level: the mid level's own cells stand
    assert marked(job("b", Change("stages", "high changed", stages=("high",)))) == {"main", "go1"}
    # a retrained mid level makes every cell of the job other, the high level trained on it included
    assert marked(job("c", Change("stages", "both changed", stages=("mid", "high")))) == {"main", "go1", "mid"}
    assert marked(job("d", Change("stages", "mid changed", stages=("mid",)))) == {"main", "go1", "mid"}
    assert marked(job("e", Change("evaluations", "main -> go1, main"))) == {"main", "go1", "mid"}
    assert marked(job("f", None)) == set()


def test_a_mid_level_under_a_high_level_is_judged_by_its_own_curve_and_drawn(cli, tmp_path):
    def points(rates):
        return [{"iteration": k, "env_steps": (k + 1) * 2_000_000, "success_rate": sr} for k, sr in enumerate(rates)]

    mids = {0: [0.5, 0.7, 0.76, 0.8, 0.82], 1: [0.4, 0.6, 0.7, 0.72, 0.8], 2: None}  # seed 2: its runs were gone
    root = tmp_path / "runs" / "scale_quick"
    for seed, rates in mids.items():
        job = root / f"agents=3,method=ours,seed={seed},task=cylinder"
        job.mkdir(parents=True)
        result = {
            "table": "scale", "variant": "quick", "method": "ours", "task": "cylinder", "num_agents": 3, "seed": seed,
            "stages": {"mid": "gone/mid", "high": "gone/high"},
            "evals": {"main": {"success_rate": 0.8, "completion_time": 0.5}},
            "curve": {"eval": "main", "every_env_steps": 2e6, "reach": 0.5, "rule": RULE,
                      "points": points([0.6, 0.7, 0.8])},
        }  # fmt: skip
        if rates:
            result["stage_curves"] = {"mid": {"every_env_steps": 2e6, "rule": RULE, "points": points(rates)}}
        (job / RESULT).write_text(json.dumps(result))
    proc = cli("tables", "--runs", tmp_path / "runs", "--out", tmp_path / "out", "--table", "scale")
    assert proc.returncode == 0, proc.stderr
    side = json.loads((tmp_path / "out" / "scale_quick.json").read_text())
    found = {(f["key"], f["about"]): f for f in side["findings"]}
    # the last fifth of 10M: 8M -> 10M, seed 0 +2 and seed 1 +8 points: +5.0 +- 3.0, over the 2 seeds with a curve
    mid = found["budget", "3 robots, mid level"]
    assert mid["holds"] is False and mid["numbers"] == pytest.approx(
        {"tail_gain_points": 5.0, "tail_gain_std": 3.0, "limit_points": 3.0, "jobs_without_curve": 1}
    )
    assert found["budget", "3 robots"]["numbers"]["tail_gain_points"] == pytest.approx(10.0)  # the hierarchy's
    assert (tmp_path / "out" / "scale_quick_mid_curves.png").stat().st_size > 1000


def test_the_scale_table_judges_the_papers_readings_of_its_figure_from_hand_made_results():
    from mapush.report.tables import BUILDERS

    # (robots: hierarchy S.R. per seed, C.T., mid level S.R. per seed); 6 robots lie outside the paper's figure
    results = scale_jobs({
        1: ((0.1, 0.2), 0.9, (0.4, 0.4)),
        2: ((0.5, 0.7), 0.6, (0.3, 0.5)),
        3: ((0.8, 0.9), 0.4, (0.7, 0.7)),
        4: ((0.7, 0.8), 0.5, (0.8, 0.8)),
        6: ((0.95, 0.95), 0.3, (0.99, 0.99)),
    })  # fmt: skip
    table = BUILDERS["scale"](results, "quick")
    # hierarchy: 15 +- 5, 60 +- 10, 85 +- 5, 75 +- 5 %; C.T. 0.9, 0.6, 0.4, 0.5; mid level: 40, 40 +- 10, 70, 80 %:
    # every reading holds for the hierarchy (C.T. too), none for the mid level (1 and 2 robots tie at 40 %)
    claims = ("one_struggles", "two_improve", "three_best", "four_worse")
    verdicts = {(f.key, f.about): f.holds for f in table.findings if f.key in claims}
    levels = {"whole hierarchy": True, "whole hierarchy, C.T.": True, "mid level alone": False}
    assert verdicts == {(key, about): holds for (key, about) in verdicts for level, holds in levels.items()
                        if about == level} and len(verdicts) == 9  # fmt: skip
    assert table.finding("two_improve", "whole hierarchy").numbers == pytest.approx(
        {"left": 60.0, "right": 15.0, "spread": 11.180}, abs=1e-3
    )  # spread: 10 and 5 in quadrature
    assert table.finding("four_worse", "mid level alone").numbers == pytest.approx({"left": 80.0, "right": 70.0})
    best = table.finding("three_best", "whole hierarchy")
    assert best.numbers == pytest.approx({"1 robot": 15.0, "2 robots": 60.0, "3 robots": 85.0, "4 robots": 75.0})
    # rows of an earlier recipe (\u2020): the findings that read them count them, those that do not stay as they were
    earlier = Change("stages", "its stages changed", ("mid",))
    marked = [dataclasses.replace(r, made_otherwise=earlier) if r.num_agents in (4, 6) else r for r in results]
    table = BUILDERS["scale"](marked, "quick")
    for claim, count in (("four_worse", 1.0), ("one_struggles", 1.0), ("two_improve", None)):
        for level in ("whole hierarchy", "mid level alone"):
            assert table.finding(claim, level).numbers.get("cells_made_otherwise") == count, (claim, level)


def test_the_scale_table_shows_the_share_of_episodes_a_fall_ended_per_robot_count():
    from mapush.report.tables import BUILDERS

    def job(n: int, seed: int, exceptions: dict | None) -> JobResult:
        main = {"success_rate": 0.5, "completion_time": 0.5}
        main |= {} if exceptions is None else {"exceptions": exceptions}
        return JobResult(job_dir=f"agents={n},seed={seed}", table="scale", variant="quick", num_agents=n, seed=seed,
                         evals={"main": main})  # fmt: skip

    results = [
        job(2, 0, {"robot_tilt": 0.2, "robot_collision": 0.1}),
        job(2, 1, {"robot_tilt": 0.4}),
        job(3, 0, {"robot_collision": 0.3}),  # no fall among its exceptions: none ended by one
        job(4, 0, None),  # a record that names no exceptions: no figure
    ]
    table = BUILDERS["scale"](results, "quick")
    assert table.columns[-1] == "Falls (%) \u2193"
    falls = {labels[0]: cells[-1] for labels, cells in table.rows}
    assert (falls["2"].mean, falls["2"].std) == pytest.approx((30.0, 10.0))
    assert falls["3"].values == [0.0] and falls["4"].values == [] and falls["4"].mean is None


def test_the_team_table_gives_each_cell_its_capacity_margin_and_the_fewest_robots_that_push(tmp_path):
    from mapush.report.plots import team_plot
    from mapush.report.team_table import team_table

    # cuboid: one robot pushes 2 and 8 kg (90 %), two robots 24 kg, nobody 64 kg; the cylinder has no job yet
    rates = {1: (0.9, 0.9, 0.1, 0.0), 2: (0.9, 0.9, 0.8, 0.2), 3: (0.9, 0.9, 0.9, 0.3), 4: (0.8, 0.8, 0.9, 0.4)}

    def evals(made):
        return {f"m{m}": {"success_rate": sr, "object_mass_kg": m} for m, sr in zip((2, 8, 24, 64), made, strict=True)}

    results = [
        JobResult(job_dir=f"agents={n},seed={seed}", table="team", variant="quick", num_agents=n, seed=seed,
                  task="cuboid", evals=evals(made), physics=RANGED)
        for n, made in rates.items() for seed in (0, 1)
    ]  # fmt: skip
    table = team_table(results, "quick")
    assert table.columns == ["2 kg", "8 kg", "24 kg", "64 kg"]
    cells = dict((tuple(labels), cells) for labels, cells in table.rows)
    # two robots at 24 kg: 24 kg x 9.81 x the mean friction 0.3 / (2 x 50 N) = 0.71
    assert cells[("cuboid", "2")][2].text() == "80.0 \u00b1 0.0 [margin 0.71]"
    assert cells[("cylinder", "3")][0].text().startswith("\u2014")  # no job: an empty cell
    assert "cylinder / 1 robot: no finished job" in table.missing
    partial = [dataclasses.replace(r, evals={k: v for k, v in r.evals.items() if k != "m64"}) if r.num_agents == 4
               else r for r in results]  # fmt: skip
    assert "cuboid / 4 robots / 64 kg: no job evaluated it (m64)" in team_table(partial, "quick").missing
    found = table.finding("fewest_robots", "cuboid")
    assert found.numbers == {"2_kg_robots": 1, "8_kg_robots": 1, "24_kg_robots": 2}  # 64 kg: none of the four
    team_plot(table, tmp_path / "team.png")
    assert (tmp_path / "team.png").stat().st_size > 0


def test_the_team_table_says_what_ended_each_robot_counts_episodes_over_its_masses_and_seeds():
    from mapush.report.team_table import team_table

    def evals(exceptions):  # the same exceptions at every mass but 64 kg, whose record names none
        made = {f"m{m}": {"success_rate": 0.5, "exceptions": exceptions, "object_mass_kg": m} for m in (2, 8, 24)}
        return made | {"m64": {"success_rate": 0.0, "object_mass_kg": 64}}

    made = {1: {"robot_tilt": 0.3}, 3: {"robot_collision": 0.6, "robot_tilt": 0.0}, 4: {"robot_tilt": 0.0}}
    results = [
        JobResult(job_dir=f"agents={n},seed=0", table="team", variant="quick", num_agents=n, seed=0, task="cuboid",
                  evals=evals(exceptions), physics=RANGED)
        for n, exceptions in made.items()
    ] + [
        JobResult(job_dir="agents=1,seed=1", table="team", variant="quick", num_agents=1, seed=1, task="cuboid",
                  evals=evals({"robot_collision": 0.1}), physics=RANGED)
    ]  # fmt: skip
    found = team_table(results, "quick").finding("ended_by", "cuboid")
    # 1 robot: falls 30 % in seed 0 and none in seed 1: 15 %; collisions 5 %; 2 robots have no job; 4 robots: none
    assert found.holds is None and found.numbers == pytest.approx(
        {"1 robot robot_tilt": 15.0, "1 robot robot_collision": 5.0, "3 robots robot_collision": 60.0}
    )


def test_the_team_table_weighs_a_policy_trained_over_the_masses_against_one_trained_at_the_objects_own():
    from mapush.report.team_table import team_table

    def curve(*rates):  # a curve evaluated every 2M env-steps
        points = [{"env_steps": 2e6 * (k + 1), "success_rate": r} for k, r in enumerate(rates)]
        return {"points": points, "rule": {"tail": 0.2, "max_gain": 0.03}}

    team = [  # one robot over 2-64 kg: 20 and 10 % at 2 and 8 kg (the cuboid's own 4 kg lies between), curve to 6M
        JobResult(job_dir=f"team,seed={seed}", table="team", variant="quick", num_agents=1, seed=seed, task="cuboid",
                  evals={f"m{m}": {"success_rate": sr, "object_mass_kg": m}
                         for m, sr in ((2, 0.2), (8, 0.1), (24, 0.0), (64, 0.0))},
                  curve=curve(0.1, 0.2, 0.2), physics=RANGED)
        for seed in (0, 1)
    ]  # fmt: skip

    def one_mass(job_dir, run, rates, table="main", overrides=()):
        return JobResult(job_dir=job_dir, table=table, variant="quick", method="sa", method_label="SA", num_agents=1,
                         task="cuboid", stages={"mid": run}, overrides=list(overrides),
                         stage_curves={"mid": curve(*rates)},
                         physics=ObjectPhysics(mass_kg=4.0, friction=(0.2, 0.4)))  # fmt: skip

    references = [
        one_mass("sa,seed=0", "runs/mid0", (0.3, 0.6, 0.8, 0.9)),  # at 6M: 80 %
        one_mass("sa,seed=1", "runs/mid1", (0.3, 0.5, 0.6, 0.9)),  # at 6M: 60 %
        one_mass("scale,seed=1", "runs/mid1", (0.3, 0.5, 0.6, 0.9), table="scale"),  # the same run, taken: once
        one_mass("heavy", "runs/mid2", (0.0, 0.0, 0.0, 0.0), overrides=["task.object.mass=24"]),  # not its own mass
    ]
    found = [f for f in team_table(team + references, "quick").findings if f.key == "own_mass"]
    assert keys(found) == [("own_mass", "cuboid / 1 robot")]  # only the cuboid's one robot has jobs of both kinds
    # at 2 and 8 kg, either side of its own 4 kg: 20 and 10 %; at its own mass (the two runs, once each): 70 +- 10 %
    assert found[0].holds is False and found[0].numbers == pytest.approx(
        {"range_points": 20.0, "one_mass_points": 70.0, "gap_points": 50.0, "spread_points": 10.0}
    )
    below = [one_mass("sa,seed=0", "runs/mid0", (0.1, 0.1, 0.15, 0.3))]  # 15 % at 6M: below the range's 20 %
    close = team_table(team + below, "quick").finding("own_mass", "cuboid / 1 robot")
    assert close.holds is True and close.numbers["gap_points"] == pytest.approx(-5.0)  # the range gains 5 points
    other_rules = [dataclasses.replace(r, rules="original") for r in references[:2]]  # the study's: strict
    assert not [f for f in team_table(team + other_rules, "quick").findings if f.key == "own_mass"]


def test_the_team_table_weighs_its_cells_against_policies_trained_at_one_evaluated_mass_alone():
    from mapush.report.team_table import team_table

    def job(seed, rates, overrides=(), variant="quick"):  # one robot on the cuboid, S.R. at 2 / 8 / 24 / 64 kg
        masses = (2, 8, 24, 64)
        evals = {f"m{m}": {"success_rate": sr, "object_mass_kg": m} for m, sr in zip(masses, rates, strict=True)}
        return JobResult(job_dir=f"{variant},seed={seed}", table="team", budget="quick", variant=variant, seed=seed,
                         num_agents=1, task="cuboid", overrides=list(overrides), evals=evals,
                         physics=physics_of(overrides))  # fmt: skip

    ranged = [job(0, (0.4, 0.6, 0.0, 0.0)), job(1, (0.4, 0.4, 0.0, 0.0))]  # 8 kg: 50 +- 10 %
    at_8 = ["task.object.mass_range=null", "task.object.mass=8.0"]
    alone = [job(s, (0.1, sr, 0.0, 0.0), at_8, "quick_mass-8") for s, sr in ((0, 0.9), (1, 0.7))]  # 8 kg: 80 +- 10
    assert alone[0].trained_mass_kg() == 8.0 and ranged[0].trained_mass_kg() is None
    assert job(0, (0,) * 4, ["task.object.mass=8.0"]).trained_mass_kg() is None  # the range still drawn: not one mass
    found = [f for f in team_table(ranged + alone, "quick").findings if f.key == "mass_alone"]
    assert keys(found) == [("mass_alone", "cuboid / 1 robot at 8 kg")]  # only the mass they trained at
    # 8 kg: the range 50 +- 10 %, alone 80 +- 10 %: it costs 30 points, beyond the spread (20)
    expected = {"range_points": 50.0, "one_mass_points": 80.0, "gap_points": 30.0, "spread_points": 20.0}
    assert found[0].holds is False and found[0].numbers == pytest.approx(expected)
    other = [job(s, (0.0, 0.9, 0.0, 0.0), [*at_8, "lowlevel=go1"], "quick_go1") for s in (0, 1)]  # made otherwise
    assert [f for f in team_table(ranged + alone + other, "quick").findings if f.key == "mass_alone"] == found
    close = [job(s, (0.1, sr, 0.0, 0.0), at_8, "quick_mass-8") for s, sr in ((0, 0.6), (1, 0.5))]
    near = team_table(ranged + close, "quick").finding("mass_alone", "cuboid / 1 robot at 8 kg")
    assert near.holds is True and near.numbers["one_mass_points"] == pytest.approx(55.0)  # costs 5, within 15
    table = team_table(ranged + alone, "quick")  # the one-mass jobs fill no cell of the study's own table
    assert [c.values for (task, n), cells in table.rows if (task, n) == ("cuboid", "1") for c in cells] == [
        [40.0, 40.0],
        [60.0, 40.0],
        [0.0, 0.0],
        [0.0, 0.0],
    ]
    assert team_table(ranged + alone, "quick_mass-8") is None  # nor a table of their own: they are its check


def test_a_row_trained_at_every_mass_alone_is_drawn_from_those_policies_and_marked(tmp_path):
    from mapush.report.formats import ALONE
    from mapush.report.plots import team_plot
    from mapush.report.team_table import team_table

    def job(seed, rates, overrides=(), variant="quick", exceptions=None):  # one robot on the cylinder
        evals = {f"m{m}": {"success_rate": sr, "object_mass_kg": m} | ({"exceptions": exceptions} if exceptions else {})
                 for m, sr in zip((2, 8, 24, 64), rates, strict=True)}  # fmt: skip
        curve = {
            "eval": "m8",
            "points": [{"env_steps": 2e6 * k, "success_rate": 0.1 * k} for k in (1, 2, 3)],
            "rule": {"tail": 0.2, "max_gain": 0.03},
        }  # the study's curves: each policy evaluated at 8 kg
        return JobResult(job_dir=f"{variant},seed={seed}", table="team", budget="quick", variant=variant, seed=seed,
                         num_agents=1, task="cylinder", overrides=list(overrides), evals=evals,
                         curve=curve, physics=physics_of(overrides))  # fmt: skip

    ranged = [job(s, (0.1, 0.1, 0.2, 0.0), exceptions={"robot_tilt": 0.5}) for s in (0, 1)]
    alone = [  # each mass's policy scores at its own mass what the rates say; elsewhere 0 (never read)
        job(s, tuple(sr if k == i else 0.0 for k in range(4)), ["task.object.mass_range=null", f"task.object.mass={m}"],
            f"quick_mass-{m}", {"robot_collision": 0.2})
        for i, (m, sr) in enumerate(((2.0, 0.4), (8.0, 0.3), (24.0, 0.3), (64.0, 0.0))) for s in (0, 1)
    ]  # fmt: skip
    table = team_table(ranged + alone, "quick")
    cells = dict((tuple(labels), cells) for labels, cells in table.rows)[("cylinder", "1")]
    assert [c.mean for c in cells] == pytest.approx([40.0, 30.0, 30.0, 0.0])  # not the range's 10 / 10 / 20 / 0
    assert all(c.mark == ALONE for c in cells) and "(cylinder / 1 robot)" in table.note
    # the design check still reads the range (10 %) against 40 % alone; what ended, the row's jobs
    check = table.finding("mass_alone", "cylinder / 1 robot at 2 kg")
    assert check.numbers == pytest.approx({"range_points": 10.0, "one_mass_points": 40.0, "gap_points": 30.0,
                                           "spread_points": 0.0})  # fmt: skip
    assert table.finding("ended_by", "cylinder").numbers == pytest.approx({"1 robot robot_collision": 20.0})
    assert "cylinder / 1 robot: no finished job" not in table.missing
    budgets = [about for key, about in keys(table.findings) if key == "budget"]
    assert budgets == ["cylinder / 1 robot", "cylinder / 1 robot at 8 kg alone"]  # the others' curves: not their mass
    dropped = [r for r in alone if "mass=64.0" not in r.overrides[1]]  # one mass short: the range's row again
    short = dict((tuple(labels), cells) for labels, cells in team_table(ranged + dropped, "quick").rows)
    assert [c.mean for c in short[("cylinder", "1")]] == pytest.approx([10.0, 10.0, 20.0, 0.0])
    assert ALONE not in team_table(ranged + dropped, "quick").note
    team_plot(table, tmp_path / "team.png")
    assert (tmp_path / "team.png").stat().st_size > 0


def test_a_mean_the_table_prints_as_50_reaches_50_in_its_finding():
    from mapush.report.team_table import team_table

    # results hold float32 rates: seeds at 42 % and 58 % average 49.99999851 in float64, printed as 50.0
    seeds = (float(np.float32(0.42)), float(np.float32(0.58)))
    assert np.mean([100 * s for s in seeds]) < 50.0
    results = [
        JobResult(job_dir=f"agents=2,seed={seed}", table="team", variant="quick", num_agents=2, seed=seed,
                  task="cylinder", evals={f"m{m}": {"success_rate": sr, "object_mass_kg": m} for m in (2, 8, 24, 64)},
                  physics=RANGED)
        for seed, sr in enumerate(seeds)
    ]  # fmt: skip
    table = team_table(results, "quick")
    cells = dict((tuple(labels), cells) for labels, cells in table.rows)
    assert cells[("cylinder", "2")][0].text().startswith("50.0 \u00b1 8.0")
    found = table.finding("fewest_robots", "cylinder")
    assert found.numbers == {"2_kg_robots": 2, "8_kg_robots": 2, "24_kg_robots": 2, "64_kg_robots": 2}


def test_curves_from_jobs_made_otherwise_are_marked_in_the_legend(tmp_path, monkeypatch):
    import matplotlib.figure

    from mapush.experiments.results import Change
    from mapush.report.formats import OTHERWISE, OTHERWISE_LEGEND
    from mapush.report.plots import curves_plot

    def job(name: str, change: Change | None) -> JobResult:
        points = [{"env_steps": k * 1e6, "success_rate": 0.1 * k} for k in (1, 2, 3)]
        stages = {"mid": "stages/m1/mid/run", "high": "stages/h1/high/run"}
        evals = {"main": {"success_rate": 0.3, "checkpoint": "stages/h1/high/run/model_48.pt"}}
        return JobResult(
            job_dir=name, method="ours", stages=stages, evals=evals, made_otherwise=change,
            curve={"eval": "main", "points": points}, stage_curves={"mid": {"points": points}},
        )  # fmt: skip

    drawn = {}

    def keep(fig, path, **kwargs):  # what the figure shows, instead of a PNG
        drawn[Path(path).name] = [fig._suptitle.get_text()] + [
            t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()
        ]

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    high_only = Change("stages", "high changed", stages=("high",))
    panels = {"Cuboid": {"SA": [job("a", high_only)], "Ours": [job("b", None)]}}
    curves_plot(panels, tmp_path / "main.png", "Main")
    curves_plot(panels, tmp_path / "mid.png", "Mid", stage="mid")
    assert drawn["main.png"] == [f"Main\n{OTHERWISE_LEGEND}", f"SA (1 seed) {OTHERWISE}", "Ours (1 seed)"]
    assert drawn["mid.png"] == ["Mid", "SA (1 seed)", "Ours (1 seed)"]  # its mid level did not change


def test_a_method_and_a_task_of_yours_get_their_column_and_rows_without_paper_numbers():
    from mapush.report.main_table import main_table

    def job(method, task, sr, label=""):
        main = {"success_rate": sr, "completion_time": 0.5}
        return JobResult(table="main", variant="quick", method=method, method_label=label, task=task, seed=0,
                         evals={"main": main}, job_dir=f"{method}-{task}")  # fmt: skip

    table = main_table([job("ours", "cuboid", 0.8), job("mine", "cuboid", 0.6, "Mine"), job("ours", "wide_box", 0.7)],
                       "quick")  # fmt: skip
    assert table.columns.index("Mine") == 6  # after the paper's six methods
    rows = {tuple(labels): cells for labels, cells in table.rows}
    mine = rows[("Cuboid", "S.R. (%) \u2191")][6]
    assert mine.values == [60.0] and mine.paper is None and mine.text() == "60.0 (1 seed)"
    wide = rows[("wide_box", "S.R. (%) \u2191")]
    assert wide[5].values == [70.0] and wide[5].paper is None  # Ours on a task the paper never ran
    assert ("ours_vs_paper", "wide_box") not in keys(table.findings)  # nothing of the paper's to hold against
    assert table.finding("ours_vs_paper", "Cuboid").numbers["ours_sr"] == pytest.approx(80.0)
    # a method of yours is no baseline of the paper's claim: at or above Ours, it is told apart, claiming nothing
    better = main_table([job("ours", "cuboid", 0.8), job("sa", "cuboid", 0.5), job("mine", "cuboid", 0.9, "Mine")],
                        "quick")  # fmt: skip
    baselines = better.finding("ours_above_baselines", "Cuboid")
    assert baselines.holds is True and baselines.numbers == pytest.approx({"SA": 50.0, "Ours": 80.0})  # no Mine
    yours = better.finding("yours_beside_ours", "Cuboid")
    assert yours.holds is None and yours.numbers == pytest.approx({"Mine": 90.0})


def test_a_side_variant_lists_missing_only_the_cells_of_the_methods_and_objects_it_ran():
    from mapush.report.main_table import main_table

    def job(variant, task):
        ev = {"main": {"success_rate": 0.0, "completion_time": 1.0, "timeout_s": 160.0}}
        return JobResult(method="hl_ft", task=task, seed=0, evals=ev, table="main", variant=variant, job_dir=task)

    side = main_table([job("long", "tblock"), job("long", "cuboid"), job("quick", "cuboid")], "long")
    assert side.missing == []  # H+L FT on both objects it ran; the other 50-odd cells were never its to fill
    quick = main_table([job("quick", "cuboid")], "quick").missing
    assert "sa / cuboid / success_rate: no finished job" in quick
    assert "hl_ft / tblock / success_rate: no finished job" in quick and len(quick) == 58


def test_a_learner_below_the_pusher_says_what_a_longer_budget_trained_on_reached():
    from mapush.report.main_table import main_table

    def job(method, task, variant, rates=()):
        points = [{"env_steps": (k + 1) * 1_000_000, "success_rate": r} for k, r in enumerate(rates)]
        ev = {"main": {"success_rate": rates[-1] if rates else 0.8, "completion_time": 0.9, "timeout_s": 160.0}}
        if method == "hl":
            ev["path_only"] = {"success_rate": 0.48, "completion_time": 0.8, "timeout_s": 160.0}
        curve = {"rule": RULE, "points": points} if rates else None
        return JobResult(method=method, task=task, seed=0, evals=ev, curve=curve, table="main", variant=variant,
                         job_dir=f"{variant}/{method}/{task}")  # fmt: skip

    quick = [job("ours", t, "quick") for t in ("cuboid", "tblock")]
    quick += [job("hl", t, "quick", [0.0] * 5) for t in ("cuboid", "tblock")]
    quick += [job("hl_ft", t, "quick", [0.0] * 5) for t in ("cuboid", "tblock")]
    longer = [job("hl_ft", "cuboid", "long", [0.0] * 5 + [0.2, 0.4, 0.48, 0.7, 0.8]),  # 0.48 reaches 48 as printed
              job("hl_ft", "tblock", "long", [0.0] * 10)]  # fmt: skip
    table = main_table([*quick, *longer], "quick")
    cuboid, tblock = (table.finding("hl_ft_vs_pusher", task) for task in ("Cuboid", "T-shape"))
    # trained on to 10M env-steps: the cuboid's first reached 48 % at the checkpoint of 8M and ended at 80 %
    assert cuboid.holds is False and {k: v for k, v in cuboid.numbers.items() if "longer" in k} == pytest.approx(
        {"env_steps_longer": 10_000_000, "env_steps_to_pusher_longer": 8_000_000, "sr_longer": 80.0}
    )
    assert tblock.numbers["env_steps_to_pusher_longer"] is None and tblock.numbers["sr_longer"] == 0.0  # never
    assert "env_steps_longer" not in table.finding("hl_vs_pusher", "Cuboid").numbers  # no longer budget trained H+L
    assert not any("env_steps_longer" in f.numbers for f in main_table(quick, "quick").findings)  # nor without them
    longer[1].made_otherwise = Change("stages", "its stages changed", ("high",))  # the T-block's: an earlier recipe
    marked = main_table([*quick, *longer], "quick").finding("hl_ft_vs_pusher", "T-shape")
    assert marked.numbers["longer_made_otherwise"] == 1.0 and "longer_made_otherwise" not in cuboid.numbers
