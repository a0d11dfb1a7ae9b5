"""Run files read without harm (`mapush.untrusted`): YAML without aliases, no link out of a run, one trainer."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mapush.errors import BadInput
from mapush.untrusted import load_yaml, read_yaml, refuse_links_out, run_lock


def test_a_stage_record_with_aliases_is_refused_naming_it(tmp_path):
    record = tmp_path / "stage.yaml"
    record.write_text("a: &x [1, 2]\nb: *x\n")
    with pytest.raises(BadInput, match=r"stage\.yaml.*anchor or alias 'x'"):
        read_yaml(record)


def test_yaml_as_mapush_writes_it_reads_as_omegaconf_reads_it(tmp_path):
    path = tmp_path / "config.yaml"
    path.write_text("lr: 1e-3\ncommand: mapush train 'a*b' x&y\nlist: ['*', '&']\n")
    assert read_yaml(path) == {"lr": 0.001, "command": "mapush train 'a*b' x&y", "list": ["*", "&"]}
    assert load_yaml(path).lr == 0.001


def test_links_inside_a_run_are_fine_and_a_link_out_of_a_folder_in_it_is_not(tmp_path):
    run = tmp_path / "run"
    (run / ".hydra").mkdir(parents=True)
    (run / "model_0.pt").write_bytes(b"")
    (run / "latest.pt").symlink_to(run / "model_0.pt")
    refuse_links_out(run)
    (run / ".hydra" / "config.yaml").symlink_to(tmp_path / "elsewhere.yaml")
    with pytest.raises(BadInput, match=r"\.hydra/config\.yaml' is a symlink"):
        refuse_links_out(run)


HOLD = "import sys, time; from mapush.untrusted import run_lock; l = run_lock(sys.argv[1], {}); l.__enter__(); "
HOLD += "print('held', flush=True); time.sleep(60)"


@pytest.mark.parametrize(("holder_trains", "refusal"), [(True, "being trained by process"), (False, "evaluated")])
def test_a_held_run_is_refused_at_once_and_freed_with_its_holder(tmp_path, holder_trains, refusal):
    with run_lock(tmp_path, training=True):  # a run dir was trained: its lock file is there
        pass
    holder = subprocess.Popen([sys.executable, "-c", HOLD.format(holder_trains), str(tmp_path)], stdout=subprocess.PIPE)
    try:
        assert holder.stdout.readline().strip() == b"held"
        with pytest.raises(BadInput, match=refusal), run_lock(tmp_path, training=True):
            pass
        if not holder_trains:  # evaluations go side by side
            with run_lock(tmp_path, training=False):
                pass
    finally:
        holder.kill()
        holder.wait()
    with run_lock(tmp_path, training=True):  # the killed holder left nothing taken
        pass


def test_evaluating_a_dir_no_one_trained_writes_no_lock_file(tmp_path):
    with run_lock(tmp_path, training=False):  # a shipped policy, perhaps in a read-only install
        pass
    assert list(tmp_path.iterdir()) == []
