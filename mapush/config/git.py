"""The state of the mapush checkout a run records: its commit and whether it has uncommitted changes."""

from __future__ import annotations

import subprocess

from mapush.config import groups


def git_state() -> dict:
    """The commit of the mapush checkout and whether it has uncommitted changes (None outside git: a wheel)."""
    root = groups.CONF_DIR.parent  # inside the checkout (git finds the repository from any dir in it)
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True)
        status = subprocess.run(["git", "status", "--porcelain"], cwd=root, capture_output=True, text=True)
        return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}
    except (OSError, subprocess.CalledProcessError):
        return {"commit": None, "dirty": None}
