"""The `mapush` command line: train, eval, play, ship (`runs`), sweep, ablate, scale, tables, archive, stages
(`experiments`), bench, plan, calibrate, plot (`tools`), probe (`probe`), logs (`logs`).

Every command takes Hydra overrides (`key=value`); bad input is one line on stderr and exit code 2 (`main`).
"""

from __future__ import annotations

import errno
import os
import sys

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython; no git binary must not kill us

# isort: off
from mapush.cli import runs, experiments, tools, probe, logs  # noqa: F401  (each registers its commands on `app`, in `--help`'s order)

# isort: on
from mapush.cli.app import app
from mapush.errors import BadInput

VALID_PATH = {
    errno.EROFS: "a writable dir with free space",
    errno.ENOSPC: "a writable dir with free space",
    errno.EDQUOT: "a writable dir with free space",
    errno.EFBIG: "a writable dir with free space",
    errno.EACCES: "a path you may read and write",
    errno.EPERM: "a path you may read and write",
    errno.ENOENT: "a path that exists (its parent dirs for an output)",
    errno.ENOTDIR: "a path whose parents are dirs",
    errno.EISDIR: "a file there, not a dir",
    errno.EEXIST: "a path not taken yet",
    errno.ENOTEMPTY: "an empty dir, or a path not taken yet",
    errno.ENAMETOOLONG: "names of at most 255 bytes in paths of at most 4095",
    errno.ELOOP: "a path without a loop of symlinks",
    errno.EMLINK: "a dir with fewer entries",
    errno.EXDEV: "a path on the same filesystem",
    errno.EBUSY: "a path no other program holds",
    errno.ETXTBSY: "a path no other program holds",
    errno.EIO: "a disk that reads and writes (check it)",
    errno.EMFILE: "fewer open files (raise ulimit -n)",
    errno.ENFILE: "fewer open files (raise ulimit -n)",
}
"""Where the disk, not mapush, refused (a read-only or full filesystem, no permission, a path that cannot be):
each errno with what would be valid instead."""


def _filesystem_line(err: OSError) -> str:
    """One line for a filesystem error: the path (cut to a readable length), the system's words, what is valid."""
    name = "" if err.filename is None else str(err.filename)
    shown = repr(name if len(name) <= 200 else f"{name[:120]}...{name[-60:]} ({len(name)} characters)")
    where = f" {shown}" if name else ""
    return f"mapush: error: the filesystem refused{where}: {err.strerror}; valid: {VALID_PATH[err.errno]}"


def main() -> None:
    """Entry point: BadInput and a filesystem's refusal (`VALID_PATH`) become one line on stderr and exit code 2."""
    try:
        app()
    except BadInput as err:
        print(f"mapush: error: {err}", file=sys.stderr)
        sys.exit(2)
    except OSError as err:
        if err.errno not in VALID_PATH:
            raise
        print(_filesystem_line(err), file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print(
            "mapush: interrupted; logs are closed (a run continues with `mapush train --resume RUN_DIR`)",
            file=sys.stderr,
        )
        sys.exit(130)
