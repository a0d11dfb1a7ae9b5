"""Sweeps on real clusters: a single-node SLURM cluster (`tools/slurm_local.sh`) and a local Ray cluster.

Each runs the 2-job OCB-ablation smoke sweep through its launcher and checks that both jobs finished and that
they ran on the cluster, not beside it. They skip, with the reason, where the cluster cannot be had.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest
from paths import REPO

from mapush.config import group_file
from mapush.experiments.results import RESULT

pytestmark = pytest.mark.xdist_group("clusters")  # one test process starts and stops the clusters, one at a time

SLURM_LOCAL = REPO / "tools" / "slurm_local.sh"
SLURM_CONF = Path("/etc/slurm/slurm.conf")
SMOKE_SWEEP = ["experiment=ocb_ablation", "budget=smoke", "debug=smoke", "seed=0", "method=ours,ours_no_ocb"]
"""The 2-job sweep of tests/unit/experiments/test_experiments.py's launcher test: Ours and Ours w/o OCB, one seed."""


def _sweep(cli, tmp_path: Path, *args: str):
    """The smoke sweep through the real CLI; a cluster starts its workers first, slowly on a busy machine."""
    from conftest import _run_cli

    return _run_cli(["sweep", *SMOKE_SWEEP, f"sweep_root={tmp_path / 'sweeps'}", *args], cwd=tmp_path, timeout=900)


def _check_both_jobs_finished(proc, sweeps: Path) -> None:
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "2 jobs finished, 0 failed" in proc.stdout
    results = [json.loads(p.read_text()) for p in sweeps.glob(f"*/*/{RESULT}")]
    assert sorted(r["method"] for r in results) == ["ours", "ours_no_ocb"]
    for result in results:
        assert set(result["evals"]) == set(group_file("experiment", "ocb_ablation").evals) >= {"t20", "t40"}


def _slurm_unavailable() -> str | None:
    """Why tools/slurm_local.sh cannot run here, or None."""
    if os.geteuid() != 0:
        return "tools/slurm_local.sh needs root (it installs Debian packages and starts system daemons)"
    if not shutil.which("slurmctld") and not shutil.which("apt-get"):
        return "SLURM is not installed and there is no apt-get to install it (tools/slurm_local.sh needs Debian)"
    if SLURM_CONF.exists() and "tools/slurm_local.sh" not in SLURM_CONF.read_text():
        return f"{SLURM_CONF} is a site's own SLURM config; the test cluster would replace it"
    return None


@pytest.fixture(scope="module")
def slurm_partition():
    """The partition of a running single-node SLURM cluster: started by the script (and stopped after the tests)
    unless it was up already."""
    reason = _slurm_unavailable()
    if reason:
        pytest.skip(reason)
    was_up = subprocess.run(["bash", str(SLURM_LOCAL), "status"], capture_output=True).returncode == 0
    proc = subprocess.run(["bash", str(SLURM_LOCAL)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    partitions = subprocess.run(["sinfo", "-h", "-o", "%P"], capture_output=True, text=True).stdout.split()
    yield next(p.rstrip("*") for p in partitions if p.endswith("*"))  # sinfo marks the default partition with a *
    if not was_up:
        subprocess.run(["bash", str(SLURM_LOCAL), "stop"], capture_output=True, timeout=120)


def _settled_job(task: str, wait_s: float = 120.0) -> str:
    """`scontrol show job` once SLURM has left RUNNING/COMPLETING: submitit reads a task's result file as soon as
    the task writes it, which can be before the batch script exits and SLURM marks the job COMPLETED."""
    deadline = time.monotonic() + wait_s
    while True:
        job = subprocess.run(["scontrol", "show", "job", task], capture_output=True, text=True).stdout
        state = re.search(r"JobState=(\w+)", job)
        if state is None or state.group(1) not in ("RUNNING", "COMPLETING") or time.monotonic() > deadline:
            return job
        time.sleep(1.0)


@pytest.mark.slow
def test_a_2_job_smoke_sweep_runs_as_slurm_jobs_on_the_local_cluster(cli, tmp_path, slurm_partition):
    # Site settings that fit a 2-core node: the config's 16 CPUs and 32 GB would leave the jobs pending forever.
    site = [f"hydra.launcher.partition={slurm_partition}", "hydra.launcher.cpus_per_task=1",
            "hydra.launcher.mem_gb=1", "hydra.launcher.timeout_min=10"]  # fmt: skip
    proc = _sweep(cli, tmp_path, "launcher=slurm", *site)
    _check_both_jobs_finished(proc, tmp_path / "sweeps")
    # submitit keeps each array task's files in .submitit/<array job>_<task>/; SLURM itself knows both tasks.
    tasks = sorted(p.name for p in (tmp_path / "sweeps").glob("*/.submitit/*_*") if p.is_dir())
    assert len(tasks) == 2, tasks
    for task in tasks:
        job = _settled_job(task)
        assert "JobState=COMPLETED" in job and f"Partition={slurm_partition}" in job, job
        logs = "".join(p.read_text() for p in (tmp_path / "sweeps").glob(f"*/.submitit/{task}/{task}_0_log.*"))
        assert f"JobEnvironment(job_id={task}," in logs  # submitit read the job id from SLURM's environment


@pytest.mark.slow
@pytest.mark.skipif(
    importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None,
    reason="the ray extra is not installed (pip install -e .[ray]; or EXTRAS=test,ray bash tools/setup.sh)",
)
def test_a_2_job_smoke_sweep_runs_as_ray_tasks_on_a_local_ray_cluster(cli, tmp_path, monkeypatch):
    # Ray starts its local cluster under RAY_TMPDIR: a short path, as its unix sockets' paths must fit 107 bytes.
    ray_tmp = Path(tempfile.mkdtemp(prefix="mapush-ray-"))
    monkeypatch.setenv("RAY_TMPDIR", str(ray_tmp))
    monkeypatch.setenv("RAY_worker_niceness", "0")  # its raylet nices workers by default: starved on a busy machine
    try:
        proc = _sweep(cli, tmp_path, "launcher=ray")
        _check_both_jobs_finished(proc, tmp_path / "sweeps")
        assert list(ray_tmp.glob("ray/session_*/logs")), "no Ray session was started"
        assert "(_run_job pid=" in proc.stdout  # Ray's prefix on its workers' output: the jobs ran as Ray tasks
    finally:
        shutil.rmtree(ray_tmp, ignore_errors=True)
