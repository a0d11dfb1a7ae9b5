"""Child processes that end with their parent: a killed `mapush bench --learn` must not leave its `mapush train`
training on, unseen, beside the next benchmark.

On Linux the child asks the kernel for SIGTERM when its parent dies (`prctl(PR_SET_PDEATHSIG)`), however the
parent dies (SIGKILL included); a `mapush` child then closes its logs as on any SIGTERM. Elsewhere nothing is armed.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
from collections.abc import Callable

PR_SET_PDEATHSIG = 1
"""prctl's option: the signal the calling process gets when its parent thread ends (linux/prctl.h)."""


def dies_with_parent() -> Callable[[], None] | None:
    """A `preexec_fn` for `subprocess` (None where it cannot be done) that ends the child with SIGTERM when this
    process ends. Call it in the thread that starts the child and outlives it: the kernel watches that thread."""
    if not sys.platform.startswith("linux"):
        return None
    parent = os.getpid()
    libc = ctypes.CDLL(None, use_errno=True)  # loaded here: the child, between fork and exec, only calls it

    def arm() -> None:
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != parent:  # the parent died before the signal was armed
            os._exit(143)

    return arm
