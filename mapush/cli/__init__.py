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

FILESYSTEM_ERRORS = {errno.EROFS, errno.ENOSPC, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.ENOTDIR, errno.ENOENT}
"""Where the disk, not mapush, refused: a read-only or full filesystem, no permission, a path that cannot be."""


def main() -> None:
    """Entry point: BadInput becomes one line on stderr and exit code 2."""
    try:
        app()
    except BadInput as err:
        print(f"mapush: error: {err}", file=sys.stderr)
        sys.exit(2)
    except OSError as err:
        if err.errno not in FILESYSTEM_ERRORS:
            raise
        where = f" {err.filename!r}" if err.filename else ""
        print(
            f"mapush: error: cannot write{where}: {err.strerror}; valid: a writable dir with free space",
            file=sys.stderr,
        )
        sys.exit(2)
    except KeyboardInterrupt:
        print(
            "mapush: interrupted; logs are closed (a run continues with `mapush train --resume RUN_DIR`)",
            file=sys.stderr,
        )
        sys.exit(130)
