"""Which mapush made a file, without git: its version and a hash of its installed code and configs.

A run's `meta.json` and every `eval.json` carry `provenance()`, so that a run made from a wheel in a fresh venv
(no checkout: `commit` is null) still names the code that made it; `mapush eval` warns when a run's recorded
hash is not the running code's (`hash_differs`). Neither enters a stage's identity (that hashes `config.yaml`).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import json
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
"""The mapush package as installed: a checkout's `mapush/` (editable) or site-packages' (a wheel)."""


def package_files(package: Path = PACKAGE) -> list[Path]:
    """The package's `.py` files and its `conf/` `.yaml` files, sorted by path: what decides what a run does."""
    code = [p for p in package.rglob("*.py") if "__pycache__" not in p.parts]
    return sorted([*code, *(package / "conf").rglob("*.yaml")], key=lambda p: p.relative_to(package).as_posix())


def files_hash(package: Path = PACKAGE) -> str:
    """sha256 over each of `package_files`' path (relative, '/'-separated) and bytes."""
    digest = hashlib.sha256()
    for path in package_files(package):
        digest.update(f"{path.relative_to(package).as_posix()}\0".encode() + path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.cache
def package_hash() -> str:
    """`files_hash` of the running mapush, computed once a process (about 180 files)."""
    return files_hash()


def package_version() -> str | None:
    """mapush's installed version (its distribution's metadata); None when it is not installed (a source tree
    put on sys.path), where the package hash alone names the code."""
    try:
        return importlib.metadata.version("mapush")
    except importlib.metadata.PackageNotFoundError:
        return None


def provenance() -> dict:
    """The fields `meta.json` and `eval.json` record: `mapush_version`, `package_hash`."""
    return {"mapush_version": package_version(), "package_hash": package_hash()}


def hash_differs(recorded: dict) -> str | None:
    """A one-line warning when `recorded` (a run's meta.json) names another package hash than the running code's;
    None when they match or when it names none (a run made before mapush recorded it)."""
    theirs = recorded.get("package_hash")
    if not theirs or theirs == package_hash():
        return None
    made_by = recorded.get("mapush_version", "?")
    return (
        f"warning: this run was made by other mapush code (version {made_by}, package hash {theirs[:12]}) than "
        f"is running (version {package_version()}, {package_hash()[:12]}); its results may differ"
    )


def run_made_by_other_code(run_dir: Path) -> str | None:
    """`hash_differs` for the run at `run_dir` (its `meta.json`); None for a meta.json that cannot be read (other
    commands report that) or that predates the hash."""
    try:
        meta = json.loads((Path(run_dir) / "meta.json").read_text())
    except (OSError, ValueError):
        return None
    return hash_differs(meta) if isinstance(meta, dict) else None
