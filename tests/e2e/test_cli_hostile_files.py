"""Hostile or damaged run files through the real CLI: each refused in one line (or read as far as it is whole),
never hanging, never written through, never trained twice at once."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from conftest import MAPUSH
from stand_ins import assert_bad_input

from mapush.rundir import SHIPPED_POLICIES

ALIAS_BOMB = "\n".join(
    ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    + [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]" for k in range(1, 10)]
    + ["level: *a9", "task: *a9"]
)
"""A "billion laughs": 9^10 strings from a few hundred bytes of nested aliases."""


def test_an_alias_bomb_config_is_refused_at_once(run_copy, run_cli):
    (run_copy / "config.yaml").write_text(ALIAS_BOMB + "\n")
    proc = run_cli(["eval", run_copy, "--episodes", "1"], cwd=run_copy.parent, timeout=60)
    assert_bad_input(proc, str(run_copy / "config.yaml"), "alias", "valid:")


def test_a_log_linked_out_of_the_run_is_not_written_through(run_copy, run_cli, tmp_path, snapshot):
    outside = tmp_path / "elsewhere.log"
    outside.write_text("someone else's file\n")
    (run_copy / "train.log").unlink()
    (run_copy / "train.log").symlink_to(outside)
    before = snapshot(run_copy)
    proc = run_cli(["train", "--resume", run_copy, "train.iterations=3"], cwd=run_copy.parent)
    assert_bad_input(proc, str(run_copy / "train.log"), "symlink", str(outside))
    assert outside.read_text() == "someone else's file\n"
    assert snapshot(run_copy) == before


def test_a_dangling_link_where_a_resume_writes_its_metrics_is_refused(run_copy, run_cli, tmp_path):
    outside = tmp_path / "made_elsewhere.mcap"
    (run_copy / "metrics.1.mcap").symlink_to(outside)  # the file a resume would open next (`next_free_path`)
    proc = run_cli(["train", "--resume", run_copy, "train.iterations=3"], cwd=run_copy.parent)
    assert_bad_input(proc, str(run_copy / "metrics.1.mcap"), "symlink")
    assert not outside.exists()


def test_a_checkpoint_linked_from_elsewhere_is_not_evaluated(run_copy, run_cli, tmp_path):
    last = sorted(run_copy.glob("model_*.pt"))[-1]
    foreign = tmp_path / "foreign.pt"
    shutil.move(last, foreign)
    last.symlink_to(foreign)
    proc = run_cli(["eval", run_copy, "--episodes", "1"], cwd=run_copy.parent)
    assert_bad_input(proc, str(last), "symlink")


def _wait_for_line(proc: subprocess.Popen, timeout: float) -> str:
    deadline = time.time() + timeout
    while time.time() < deadline:
        line = proc.stdout.readline()
        if line.strip():
            return line.strip()
        if proc.poll() is not None:
            break
    raise AssertionError(f"no run dir printed: {proc.stderr.read() if proc.poll() is not None else 'timeout'}")


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_a_run_being_trained_is_not_trained_or_evaluated_beside_it(run_copy, run_cli):
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    first = subprocess.Popen(
        [*MAPUSH, "train", "--resume", str(run_copy), "train.iterations=100000"],
        cwd=run_copy.parent,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert _wait_for_line(first, 200) == str(run_copy)  # printed once the run is locked
        deadline = time.time() + 200
        while not (run_copy / "metrics.1.mcap").exists() and time.time() < deadline:
            time.sleep(0.5)  # the first trainer's own metrics file
        metrics = sorted(run_copy.glob("metrics*.mcap"))
        second = run_cli(["train", "--resume", run_copy, "train.iterations=100000"], cwd=run_copy.parent)
        assert_bad_input(second, str(run_copy), f"being trained by process {first.pid}", "valid:")
        evaluation = run_cli(["eval", run_copy, "--episodes", "1"], cwd=run_copy.parent)
        assert evaluation.returncode == 2 and "Traceback" not in evaluation.stderr  # (a provenance warning may come)
        assert f"mapush: error: {str(run_copy)!r} is being trained by process {first.pid}" in evaluation.stderr
        assert sorted(run_copy.glob("metrics*.mcap")) == metrics  # the second opened no metrics file of its own
    finally:
        first.send_signal(signal.SIGTERM)
        first.communicate(timeout=60)


def _shipped_copy(tmp_path: Path) -> Path:
    copy = tmp_path / "shipped" / "cuboid"
    shutil.copytree(SHIPPED_POLICIES / "cuboid", copy)
    return copy / "mid"


@pytest.mark.slow  # over 8 s on the idle 2-core machine (10-11 s, 2026-12-07)
def test_a_shipped_checkpoint_altered_on_disk_is_refused(tmp_path, run_cli):
    mid = _shipped_copy(tmp_path)
    checkpoint = next(mid.glob("model_*.pt"))
    data = torch.load(checkpoint, weights_only=True)
    first = next(k for k in data["actor_state_dict"] if k.endswith("weight"))
    data["actor_state_dict"][first] = torch.zeros_like(data["actor_state_dict"][first])  # loads fine, pushes nothing
    torch.save(data, checkpoint)
    proc = run_cli(["eval", mid, "--episodes", "1", "--seeds", "0"], cwd=tmp_path)
    assert_bad_input(proc, str(checkpoint), "sha256")


@pytest.mark.slow  # over 8 s on the idle 2-core machine
def test_a_killed_learning_bench_takes_its_training_along(tmp_path):
    """`mapush bench --learn`'s training child (the real `mapush train`) ends when the benchmark is killed."""
    script = (
        "import sys; from pathlib import Path; from mapush.bench.learning import train_for; "
        "train_for(['debug=smoke'], 10, 1, Path(sys.argv[1]))"
    )
    parent = subprocess.Popen([sys.executable, "-c", script, str(tmp_path / "runs")], cwd=tmp_path)
    child = None
    try:
        deadline = time.time() + 60
        while child is None and time.time() < deadline:
            children = Path(f"/proc/{parent.pid}/task/{parent.pid}/children").read_text().split()
            child = int(children[0]) if children else None
            time.sleep(0.2)
        assert child is not None, "the benchmark started no training"
        time.sleep(2)  # the child past its start, into its imports
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.time() + 10
        while _alive(child) and time.time() < deadline:
            time.sleep(0.2)
        assert not _alive(child), "the training child outlived the killed benchmark"
    finally:
        parent.kill()
        parent.wait()
        if child is not None and _alive(child):
            os.kill(child, signal.SIGKILL)


def _alive(pid: int) -> bool:
    """Whether `pid` runs (a zombie, dead but not yet reaped by init, counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, IndexError):
        return False
    return state not in ("Z", "X")


@pytest.fixture
def cut_metrics(run_copy):
    """The run copy with its metrics.mcap returned as (path, original bytes)."""
    path = run_copy / "metrics.mcap"
    return path, path.read_bytes()


def _first_chunk_end(path: Path, data: bytes) -> int:
    """The shortest prefix of the MCAP `data` that holds a complete message: the end of its first chunk."""
    from mapush.logging.mcap_files import stream_records

    low, high = 0, len(data)
    while low < high:
        middle = (low + high) // 2
        path.write_bytes(data[:middle])
        low, high = (low, middle) if stream_records(path).messages else (middle + 1, high)
    return low


def test_a_metrics_file_cut_in_its_first_chunk_says_so(cut_metrics, run_cli):
    path, data = cut_metrics
    path.write_bytes(data[: _first_chunk_end(path, data) - 8])
    proc = run_cli(["plot", path.parent, "-o", path.parent / "curves.png"], cwd=path.parent)
    assert_bad_input(proc, str(path), "cut or empty", "mapush logs recover")
    assert not (path.parent / "curves.png").exists()


def test_a_metrics_file_torn_inside_a_message_plots_what_is_whole(cut_metrics, run_cli):
    from mcap.writer import CompressionType

    from mapush.logging import mcap_files

    path, _ = cut_metrics
    plain = path.with_name("plain.mcap")
    contents = mcap_files.stream_records(path)
    with open(plain, "wb") as f:  # the same records, uncompressed, so that one message's bytes can be torn
        writer = mcap_files.Writer(f, chunk_size=2048, compression=CompressionType.NONE)
        writer.start()
        schema = {k: writer.register_schema(s.name, s.encoding, s.data) for k, s in contents.schemas.items()}
        channel = {
            k: writer.register_channel(c.topic, c.message_encoding, schema[c.schema_id])
            for k, c in contents.channels.items()
        }
        for m in contents.messages:
            writer.add_message(channel[m.channel_id], m.log_time, m.data, m.publish_time)
        writer.finish()
    data = bytearray(plain.read_bytes())
    last = data.rindex(b'{"iteration"')
    data[last] = ord("X")  # the last message torn: not JSON any more
    path.write_bytes(bytes(data))
    plain.unlink()
    proc = run_cli(["plot", path.parent, "-o", path.parent / "curves.png"], cwd=path.parent)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert (path.parent / "curves.png").is_file()
