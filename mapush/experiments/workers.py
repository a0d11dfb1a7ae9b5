"""A sweep's worker processes: the threads each job gets, and (local sweeps) an end with the sweep: a killed sweep
(even by SIGKILL) leaves no worker behind.

joblib's workers are the sweep's children. Each job starts a watch in its worker that, once the sweep process is
gone, stops the running job as SIGTERM does (logs closed, checkpoints kept, its stage lock released) and exits.
"""

from __future__ import annotations

import functools
import os
import signal
import threading
import time

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

SWEEP_PID = "MAPUSH_SWEEP_PID"
"""The local sweep's process id, for its worker processes (`stop_with_the_sweep`)."""
GRACE_S = 60.0
"""Seconds a worker whose sweep is gone has to close its job's logs before it exits anyway."""


@functools.cache
def stop_with_the_sweep() -> threading.Event:
    """In a local sweep's worker process: once the sweep that started it is gone (killed, even by SIGKILL), stop
    the running job as SIGTERM does (logs closed, checkpoints kept, its stage lock released) and exit, so that a
    killed sweep leaves no process behind. Cluster jobs (SLURM, Ray) are not the sweep's children and go on.
    Returns the event a job clears while it runs (made here, in the worker: a lock cannot travel to it)."""
    between_jobs = threading.Event()
    between_jobs.sweep_gone = False  # set by the watch below: a stop then ends the worker, not just its job
    sweep = int(os.environ.get(SWEEP_PID, "0") or 0)
    if not sweep or os.getpid() == sweep or os.getppid() != sweep:
        return between_jobs

    def watch() -> None:
        while os.getppid() == sweep:
            time.sleep(1.0)
        between_jobs.sweep_gone = True
        if not between_jobs.is_set():
            os.kill(os.getpid(), signal.SIGTERM)
            between_jobs.wait(GRACE_S)
        os._exit(143)

    threading.Thread(target=watch, name="stop-with-the-sweep", daemon=True).start()
    return between_jobs


def job_threads(cfg: DictConfig) -> int:
    """Threads of one job: `job_threads`, or the cores it was given shared among the local launcher's concurrent
    jobs (a SLURM or Ray job gets its allocation, not the node's every core)."""
    if int(cfg.job_threads) > 0:
        return int(cfg.job_threads)
    concurrent = int(HydraConfig.get().launcher.get("n_jobs") or 1)  # joblib's cap; others: one job per process
    return max(1, available_cores() // concurrent)


def available_cores() -> int:
    """The cores this process may use: SLURM's allocation, else the CPU affinity (containers, Ray), else all."""
    if os.environ.get("SLURM_CPUS_PER_TASK", "").isdigit():
        return int(os.environ["SLURM_CPUS_PER_TASK"])
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1
