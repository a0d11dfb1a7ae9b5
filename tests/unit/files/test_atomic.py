"""Records written whole or not at all, and writers that take turns (`mapush.atomic`)."""

from __future__ import annotations

import json
import os
import subprocess

import pytest
from conftest import MAPUSH

from mapush.atomic import HOST, remove_leftovers, replacing, temp_path, write_json
from mapush.logging.mcap_files import summary


def test_a_writer_that_fails_leaves_the_old_record_and_no_temp_file(tmp_path):
    target = write_json(tmp_path / "eval.json", {"success_rate": 0.9})
    with pytest.raises(RuntimeError), replacing(target) as tmp:
        tmp.write_text('{"success_rate": 0.')  # cut half-way, as a kill or a full disk would
        raise RuntimeError("disk full")
    assert json.loads(target.read_text()) == {"success_rate": 0.9}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval.json"]


def test_temp_files_are_hidden_and_per_process(tmp_path):
    tmp = temp_path(tmp_path / "model_5.pt")
    assert tmp.name.startswith(".") and str(os.getpid()) in tmp.name
    assert not list(tmp_path.glob("model_*.pt"))


def test_leftovers_of_dead_writers_are_removed_and_a_live_writer_s_kept(tmp_path):
    dead = subprocess.Popen(["true"])
    dead.wait()
    gone = tmp_path / f".eval.json.{HOST}.{dead.pid}.tmp"
    elsewhere = tmp_path / f".eval.json.another-host.{dead.pid}.tmp"  # a machine sharing the dir: its own to reap
    elsewhere.write_text("{")
    live = temp_path(tmp_path / "eval.json")
    gone.write_text("{")
    live.write_text("{")
    assert remove_leftovers(tmp_path) == [gone]
    assert live.exists() and elsewhere.exists() and not gone.exists()


@pytest.mark.slow
def test_two_evaluations_of_one_run_at_once_leave_every_file_whole(run_copy, tmp_path):
    """The same `mapush eval` started twice at once: the second waits for the first, both succeed, and the
    episode file and eval.json are complete."""
    cmd = [*MAPUSH, "eval", str(run_copy), "--episodes", "2", "--seeds", "0,1"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    procs = [subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in "ab"]
    for proc in procs:
        assert proc.wait(timeout=300) == 0, proc.stderr.read()
    assert summary(run_copy / "episodes.mcap")["complete"]
    assert json.loads((run_copy / "eval.json").read_text())["seeds"] == [0, 1]
    assert not list(run_copy.glob(".*.tmp"))


def test_an_evaluation_cut_midway_keeps_the_last_good_episode_file(tmp_path):
    """EpisodeRecorder(whole=True).discard(): the partial file goes, the earlier file at the name stays."""
    from mapush.config import compose_config, to_plain
    from mapush.levels import scene_layout
    from mapush.logging.episodes import EpisodeRecorder

    cfg = to_plain(compose_config(["debug=smoke"]))
    good = tmp_path / "episodes.mcap"
    good.write_bytes(b"the last good file")
    recorder = EpisodeRecorder(good, scene_layout(cfg), ["r"], ("diverged",), whole=True)
    recorder._open()  # as the first finished episode would
    assert recorder.partial.exists() and recorder.partial != good
    recorder.discard()
    assert good.read_bytes() == b"the last good file" and not recorder.partial.exists()
