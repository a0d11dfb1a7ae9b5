"""Digests of exported and shipped weight files (`mapush.digests`): recorded when written, checked when loaded."""

from __future__ import annotations

import re
import shutil

import pytest

from mapush.digests import SUMS_FILE, recorded, sha256, weight_files
from mapush.errors import BadInput
from mapush.lowlevel.go1 import load_locomotion_policy
from mapush.rl.policy import load_policy
from mapush.rundir import POLICY_FILE, SHIPPED_LOWLEVEL, SHIPPED_POLICIES

SHIPPED = sorted({p.parent for root in (SHIPPED_POLICIES, SHIPPED_LOWLEVEL) for p in root.glob("**/config.yaml")})


@pytest.mark.parametrize("shipped", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_shipped_weight_file_has_its_digest(shipped):
    # regenerate with mapush.digests.record_weights(DIR) (`mapush ship` writes them)
    assert sorted(recorded(shipped)) == weight_files(shipped)
    assert {name: sha256(shipped / name) for name in weight_files(shipped)} == recorded(shipped)


def test_a_finished_run_records_its_exported_policies(smoke_run):
    sums = recorded(smoke_run)
    assert sorted(sums) == ["policy.onnx", "policy.pt"]
    assert sums["policy.pt"] == sha256(smoke_run / POLICY_FILE)


def test_an_altered_locomotion_policy_is_refused(tmp_path):
    walker = shutil.copytree(SHIPPED_LOWLEVEL / "go1", tmp_path / "go1")
    data = bytearray((walker / POLICY_FILE).read_bytes())
    data[len(data) // 2] ^= 0x01
    (walker / POLICY_FILE).write_bytes(bytes(data))
    with pytest.raises(BadInput, match=re.escape(f"{POLICY_FILE}' does not match its sha256")):
        load_locomotion_policy(walker)


def test_a_run_made_before_digests_loads(tmp_path):
    mid = shutil.copytree(SHIPPED_POLICIES / "cuboid" / "mid", tmp_path / "mid")
    (mid / SUMS_FILE).unlink()
    assert load_policy(mid).obs_dim > 0
    load_locomotion_policy(shutil.copytree(SHIPPED_LOWLEVEL / "go1", tmp_path / "go1"))
