"""A local sweep's worker processes end with the sweep: a killed sweep (even by SIGKILL) leaves none behind.

joblib's workers are the sweep's children. Each job starts a watch in its worker that, once the sweep process is
gone, stops the running job as SIGTERM does (logs closed, checkpoints kept, its stage lock released) and exits.
"""

from __future__ import annotations

import functools
import os
import signal
import threading
import time

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
