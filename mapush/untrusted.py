"""Run-dir files that a user, a script or a damaged disk may have changed, read and written so that they do no harm.

- YAML is read without anchors or aliases (`load_yaml`, `read_yaml`): mapush never writes them (OmegaConf's
  `to_yaml` does not), and a 4 kB "billion laughs" of nested aliases expands past any memory or patience.
- No symlink leads out of a run dir (`refuse_links_out`), and logs are opened without following one (`open_own`):
  a resume appends to its logs, and would append to whatever a link points at.
- One process trains a run at a time (`run_lock`): a second trainer would overwrite the first's live metrics.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import functools
import os
from collections.abc import Iterator
from pathlib import Path

from mapush.errors import BadInput

LOCK_FILE = ".busy.lock"
"""The hidden file of a run dir that `run_lock` locks, holding the pid of the process training the run."""


def refuse_aliases(text: str, source: Path) -> None:
    """BadInput naming `source` if the YAML `text` has an anchor or an alias (`&name`, `*name`)."""
    if "&" not in text and "*" not in text:  # no anchor or alias can be written without one of them
        return
    import yaml

    for event in yaml.parse(text, Loader=_plain_loader()):
        if getattr(event, "anchor", None) is not None:
            raise BadInput(
                f"{str(source)!r} holds the YAML anchor or alias {event.anchor!r}, which mapush never writes "
                "(nested aliases expand without bound); valid: a YAML file without anchors (&) or aliases (*)"
            )


def read_yaml(source: Path):
    """A YAML file as plain Python containers, read as `OmegaConf.load` reads it (its float rule: `1e-3` is a
    float), with libyaml's C parser where it is built (stage records are read by the hundred); aliases refused."""
    import yaml

    text = Path(source).read_text()
    refuse_aliases(text, source)
    return yaml.load(text, Loader=_plain_loader())


def load_yaml(source: Path):
    """`OmegaConf.load(source)` of a file from outside the package (a run's config.yaml): aliases refused."""
    import io

    from omegaconf import OmegaConf

    text = Path(source).read_text(encoding="utf-8")
    refuse_aliases(text, source)
    return OmegaConf.load(io.StringIO(text))


@functools.cache
def _plain_loader():
    import yaml
    from omegaconf._utils import get_yaml_loader

    fast = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    loader = type("PlainLoader", (fast,), {})
    loader.yaml_implicit_resolvers = get_yaml_loader().yaml_implicit_resolvers  # OmegaConf's, floats included
    return loader


def refuse_links_out(run_dir: Path) -> None:
    """BadInput naming the first file of `run_dir` (or of a folder in it) that is a symlink leading out of it: a
    resume would write through it, an evaluation read weights or config from elsewhere."""
    root = Path(run_dir).resolve()
    folders = [Path(run_dir)]
    for folder in folders:
        with os.scandir(folder) as entries:
            for entry in entries:
                if entry.is_symlink():
                    target = Path(entry.path).resolve()
                    if not target.is_relative_to(root):
                        raise BadInput(
                            f"{entry.path!r} is a symlink to {str(target)!r}, outside the run dir; valid: a run dir "
                            "whose files are its own (replace the link by a copy of the file)"
                        )
                elif entry.is_dir(follow_symlinks=False) and folder == Path(run_dir):
                    folders.append(Path(entry.path))


def open_own(path: Path, mode: str):
    """`open(path, mode)` that never follows a symlink at `path` (O_NOFOLLOW); BadInput naming it instead."""
    try:
        return open(path, mode, opener=lambda name, flags: os.open(name, flags | os.O_NOFOLLOW, 0o666))
    except OSError as err:
        if err.errno != errno.ELOOP:
            raise
        raise BadInput(f"{str(path)!r} is a symlink; mapush writes no log through one; valid: a plain file") from None


@contextlib.contextmanager
def run_lock(run_dir: Path, training: bool) -> Iterator[None]:
    """Hold `run_dir` for this process without waiting: alone to train it (`training`), beside other evaluations
    to evaluate it. BadInput at once, naming the holder, when another process holds it so. The lock goes with the
    process (flock), so a killed holder never leaves the run locked. Only a trainer makes the lock file: an
    evaluation of a dir no process ever trained (a shipped policy, perhaps in a read-only install) writes nothing."""
    path = Path(run_dir) / LOCK_FILE
    if not training and not path.is_file():
        yield  # nothing trains it now: a trainer makes the file before it starts
        return
    fd = os.open(path, os.O_NOFOLLOW | (os.O_RDWR | os.O_CREAT if training else os.O_RDONLY), 0o644)
    try:
        try:
            fcntl.flock(fd, (fcntl.LOCK_EX if training else fcntl.LOCK_SH) | fcntl.LOCK_NB)
        except BlockingIOError:
            raise BadInput(_holder(fd, run_dir, training)) from None
        if training:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def _holder(fd: int, run_dir: Path, training: bool) -> str:
    """The line that refuses a second holder: who holds the run, and what to do."""
    then = "then train it" if training else "then evaluate it"
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)  # taken: only evaluations hold it
        return f"{str(run_dir)!r} is being evaluated by another process; valid: wait until it ends, {then}"
    except BlockingIOError:
        pid = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
        return f"{str(run_dir)!r} is being trained by process {pid}; valid: wait until it ends (or stop it), {then}"
