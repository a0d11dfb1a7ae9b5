"""The machine record in eval.json: it tells machines that round differently apart, and alike ones together."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import torch

from mapush.eval.numerics import computes_alike, machine_record

RECORD = "import json; from mapush.eval.numerics import machine_record; print(json.dumps(machine_record()))"


def _record_with(env: dict) -> dict:
    """The machine record of a new process with `env` added to this one's environment."""
    proc = subprocess.run(
        [sys.executable, "-c", RECORD], capture_output=True, text=True, check=True, env={**os.environ, **env}
    )
    return json.loads(proc.stdout)


def test_the_record_is_the_same_in_another_process_on_this_machine():
    here, there = machine_record(), _record_with({})
    assert here == there and computes_alike(here, there)


@pytest.mark.skipif(torch.backends.cpu.get_cpu_capability() == "DEFAULT", reason="no vector kernels to turn off")
def test_torch_s_scalar_kernels_are_another_machine():
    """ATEN_CPU_CAPABILITY=default makes torch dispatch as a CPU without vector units would: other kernels, other
    last bits (measured: the shipped T-block hierarchy's seed 0 goes from 92 % to 94 % S.R.)."""
    here, scalar = machine_record(), _record_with({"ATEN_CPU_CAPABILITY": "default"})
    assert scalar["torch_cpu_capability"] == "DEFAULT"
    assert scalar["numerics"] != here["numerics"]
    assert not computes_alike(here, scalar)


def test_a_record_from_before_machines_were_recorded_promises_nothing():
    here = machine_record()
    assert not computes_alike(None, here) and not computes_alike({"cpu": here["cpu"]}, here)
    other_numpy = {**here, "libraries": {**here["libraries"], "numpy": "0.0"}}
    assert not computes_alike(other_numpy, here)
    assert computes_alike({**here, "cpu": "another model name"}, here)
