"""Shared fixtures: composed configs, small envs, the real `mapush` CLI, and one smoke run trained through it."""

from __future__ import annotations

import copy
import fcntl
import functools
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import pytest

from mapush.config import compose_config, to_plain

_CONSOLE_SCRIPT = Path(sys.executable).parent / "mapush"
_ENTRY_POINT = [sys.executable, "-c", "from mapush.cli import main; main()"]
MAPUSH = [str(_CONSOLE_SCRIPT)] if _CONSOLE_SCRIPT.is_file() else _ENTRY_POINT
"""The installed `mapush` console script of this interpreter's venv (or the same entry point through -c)."""

_COMPOSED: dict[tuple[str, ...], dict] = {}


def composed(*overrides: str) -> dict:
    """A fresh plain-dict copy of `compose_config(overrides)` (cached: composing takes Hydra a while)."""
    if overrides not in _COMPOSED:
        _COMPOSED[overrides] = to_plain(compose_config(list(overrides)))
    return copy.deepcopy(_COMPOSED[overrides])


@pytest.fixture
def cfg_for():
    """`cfg_for("task=tblock", ...)`: a composed config as a plain dict, safe to edit."""
    return composed


@pytest.fixture
def smoke_cfg() -> dict:
    """The composed `debug=smoke` config (cuboid, 2 agents, 4 envs, 1 s episodes) as a plain dict."""
    return composed("debug=smoke")


@pytest.fixture
def make_env():
    """`make_env(*overrides, num_envs=4)`: a MidPushEnv of the composed config."""
    from mapush.envs.mid import MidPushEnv

    def make(*overrides: str, num_envs: int = 4) -> MidPushEnv:
        return MidPushEnv(composed(*overrides), num_envs=num_envs)

    return make


def _run_cli(args: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run([*MAPUSH, *map(str, args)], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="session", autouse=True)
def own_cache(tmp_path_factory):
    """The tests' own mapush cache dir (remembered sweep plans): never the user's, and empty when they start."""
    from mapush.experiments.plan_memo import CACHE_ENV

    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="session")
def run_cli():
    """`run_cli(args, cwd)`: the real `mapush` command, for fixtures wider than one test."""
    return _run_cli


@pytest.fixture
def cli(tmp_path):
    """`cli("train", "debug=smoke", ...)`: run the real `mapush` command in a temp dir; a CompletedProcess. Its
    `timeout` guards against a hang, it times nothing."""

    def run(*args, timeout: float = 240) -> subprocess.CompletedProcess:
        return _run_cli(list(args), cwd=tmp_path, timeout=timeout)

    return run


def made_once(tmp_path_factory, name: str, make: Callable[[Path], None]) -> Path:
    """The folder `name` that `make(folder)` filled, made once for the whole test session: the test processes
    that xdist starts share their base temp dir's parent, and the first to ask makes it under a file lock while
    the others wait. Treat what it holds as read-only."""
    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent
    folder, done = shared / name, shared / f"{name}.done"
    with open(shared / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)  # a try that failed before
            folder.mkdir()
            make(folder)
            done.touch()
    return folder


@pytest.fixture(scope="session")
def make_once(tmp_path_factory) -> Callable[[str, Callable[[Path], None]], Path]:
    """`made_once` for a test module's own session fixture: `make_once(name, make)` is the folder `make` filled once
    for every test process."""
    return functools.partial(made_once, tmp_path_factory)


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> Path:
    """A 2-iteration `mapush train debug=smoke` run dir, made once through the CLI. Treat it as read-only."""

    def make(root: Path) -> None:
        proc = _run_cli(["train", "debug=smoke", f"train.run_root={root}"], cwd=root)
        assert proc.returncode == 0, proc.stderr
        run_dir = Path(proc.stdout.strip().splitlines()[-1])
        assert run_dir.is_dir(), proc.stdout
        (root / "run_dir.txt").write_text(str(run_dir))

    return Path((made_once(tmp_path_factory, "smoke_run", make) / "run_dir.txt").read_text())


class Resumed(NamedTuple):
    """A smoke run trained for 3 iterations with TensorBoard and progress lines on, then resumed to 6."""

    run: Path
    """The resumed run dir (6 iterations, two metrics parts)."""
    first: Path
    """A copy of the same run dir as the first part left it (3 iterations)."""
    stderr: str
    """Both commands' stderr, one after the other."""


@pytest.fixture(scope="session")
def resumed_run(tmp_path_factory) -> Resumed:
    """One run cut and resumed through the CLI, shared by the resume and metrics tests (made once for every test
    process; read-only)."""

    def make(folder: Path) -> None:
        run_dir = folder / "run"
        args = ["debug=smoke", "log.tensorboard=true", "train.progress=true", "train.iterations=3"]
        first = _run_cli(["train", *args, f"train.run_dir={run_dir}"], cwd=folder)
        assert first.returncode == 0, first.stderr
        shutil.copytree(run_dir, folder / "first")
        second = _run_cli(["train", "--resume", str(run_dir), "train.iterations=6"], cwd=folder)
        assert second.returncode == 0, second.stderr
        assert second.stdout.strip().splitlines()[-1] == str(run_dir)
        (folder / "stderr.txt").write_text(first.stderr + second.stderr)

    folder = made_once(tmp_path_factory, "resumed_run", make)
    return Resumed(folder / "run", folder / "first", (folder / "stderr.txt").read_text())


@pytest.fixture
def run_copy(smoke_run, tmp_path) -> Path:
    """A private copy of the smoke run, for commands that write into a run dir (eval, resume)."""
    target = tmp_path / "run"
    shutil.copytree(smoke_run, target)
    return target


@pytest.fixture
def snapshot():
    """`snapshot(dir)`: every file under `dir` with its size and mtime, to check that a command changed nothing
    (but the run lock's file, which holds the pid of the last process that took it, a record of nothing)."""
    from mapush.untrusted import LOCK_FILE

    def take(directory: Path) -> dict[str, tuple[int, int]]:
        return {
            str(p.relative_to(directory)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(Path(directory).rglob("*"))
            if p.is_file() and p.name != LOCK_FILE
        }

    return take
