"""Metrics get out of a run: TensorBoard event files, `mapush logs export` CSV and `logs summary` values, for a
fresh run and for one resumed to a longer budget, whose parts read as one series and whose readouts go on."""

from __future__ import annotations

import csv
import io
import math
import re

import pytest
import torch
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from mapush.logging.mcap_files import iter_json


def mcap_scalars(run_dir) -> dict[str, dict[int, float]]:
    """Every scalar of every metrics part, read straight from the MCAP messages (not through mapush's merge)."""
    found: dict[str, dict[int, float]] = {}
    for part in sorted(run_dir.glob("metrics*.mcap")):
        for topic, _, data in iter_json(part, "/metrics/"):
            found.setdefault(topic.removeprefix("/metrics/"), {})[data["iteration"]] = data["value"]
    return found


def tensorboard_scalars(run_dir) -> dict[str, dict[int, float]]:
    """Every scalar TensorBoard's own reader finds in the run's tensorboard/ folder (all its event files)."""
    events = EventAccumulator(str(run_dir / "tensorboard"), size_guidance={"scalars": 0})
    events.Reload()
    return {tag: {e.step: e.value for e in events.Scalars(tag)} for tag in events.Tags()["scalars"]}


pytestmark = pytest.mark.xdist_group("resumed_run")  # with the resume tests: one process makes `resumed_run`


@pytest.fixture
def resumed_tb(resumed_run):
    """`resumed_run` (3 iterations with TensorBoard and progress lines on, resumed to 6): (run dir, its scalars
    before the resume, both stderrs)."""
    return resumed_run.run, mcap_scalars(resumed_run.first), resumed_run.stderr


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_tensorboard_holds_every_scalar_of_both_parts_as_the_mcap_log(resumed_tb):
    run_dir, _, _ = resumed_tb
    assert len(list((run_dir / "tensorboard").glob("events.out.tfevents.*"))) == 2  # one per process
    ours, theirs = mcap_scalars(run_dir), tensorboard_scalars(run_dir)
    assert set(theirs) == set(ours)
    assert sorted(theirs["Loss/learning_rate"]) == list(range(6))
    for tag, series in ours.items():
        assert sorted(theirs[tag]) == sorted(series), tag
        for it, value in series.items():  # TensorBoard keeps float32
            assert theirs[tag][it] == pytest.approx(value, rel=1e-6, abs=1e-12, nan_ok=True), (tag, it)


def test_the_csv_export_has_a_row_per_iteration_of_the_whole_resumed_run(resumed_tb, cli):
    run_dir, _, _ = resumed_tb
    proc = cli("logs", "export", run_dir, "--csv")
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(io.StringIO(proc.stdout)))
    assert [int(r["iteration"]) for r in rows] == list(range(6))
    ours = mcap_scalars(run_dir)
    assert set(rows[0]) == {"iteration", *ours}
    for row in rows:
        for tag, series in ours.items():
            it = int(row["iteration"])
            if it in series:
                assert float(row[tag]) == pytest.approx(series[it], nan_ok=True), (tag, it)
            else:
                assert row[tag] == ""


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_the_csv_export_refuses_an_existing_output_and_keeps_it(resumed_tb, cli, tmp_path):
    run_dir, _, _ = resumed_tb
    existing = tmp_path / "metrics.csv"
    existing.write_text("mine\n")
    proc = cli("logs", "export", run_dir, "-o", existing)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "exists" in proc.stderr and existing.read_text() == "mine\n"


def test_summary_of_a_run_dir_gives_each_scalars_last_and_extremes_over_both_parts(resumed_tb, cli):
    run_dir, _, _ = resumed_tb
    proc = cli("logs", "summary", run_dir)
    assert proc.returncode == 0, proc.stderr
    lines = {line.split()[0]: line.split() for line in proc.stdout.splitlines()[2:]}
    series = mcap_scalars(run_dir)["Loss/learning_rate"]
    _, count, last, at, lowest, highest = lines["Loss/learning_rate"]
    assert int(count) == 6 and at == "(5)"
    assert float(last) == pytest.approx(series[5], rel=1e-5)
    assert float(lowest) == pytest.approx(min(series.values()), rel=1e-5)
    assert float(highest) == pytest.approx(max(series.values()), rel=1e-5)


def test_the_console_iteration_is_the_checkpoints_number(resumed_tb):
    run_dir, _, stderr = resumed_tb
    shown = [int(m) for m in re.findall(r"^iter (\d+) \(", stderr, flags=re.M)]
    assert shown == list(range(6))
    last = max(int(p.stem.split("_")[1]) for p in run_dir.glob("model_*.pt"))
    assert shown[-1] == last == 5


def test_the_reward_readout_goes_on_from_the_checkpoint_after_a_resume(resumed_tb):
    # smoke episodes last 50 steps, an iteration 8: in the first resumed iteration only the episodes the resume
    # started part-way through can end, so the readout is the checkpoint's window, not a restart from them
    run_dir, before, _ = resumed_tb
    saved = torch.load(run_dir / "model_2.pt", weights_only=True)["infos"]["readouts"]["logger"]
    assert saved["rewards"], "the first part ended whole episodes"
    after = mcap_scalars(run_dir)["Train/mean_reward"]
    assert after[3] == pytest.approx(sum(saved["rewards"]) / len(saved["rewards"]))
    assert after[2] == pytest.approx(before["Train/mean_reward"][2])
    assert not math.isnan(after[3])


def test_algo_logger_is_refused_in_one_line_and_makes_no_run(cli, tmp_path):
    proc = cli("train", "debug=smoke", "+algo.logger=tensorboard", f"train.run_dir={tmp_path / 'run'}")
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "log.tensorboard=true" in proc.stderr
    assert not (tmp_path / "run").exists()
