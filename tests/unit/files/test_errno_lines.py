"""Every filesystem refusal (`mapush.cli.VALID_PATH`) is one line naming the path, the system's words and what is
valid, exit code 2: no traceback, and no "cannot write" for a read."""

from __future__ import annotations

import errno
import os

import pytest

import mapush.cli as cli


@pytest.mark.parametrize(
    ("code", "valid"),
    [
        (errno.ENAMETOOLONG, "at most 255 bytes"),
        (errno.EISDIR, "not a dir"),
        (errno.EEXIST, "not taken yet"),
        (errno.ENOTEMPTY, "an empty dir"),
        (errno.ELOOP, "without a loop of symlinks"),
        (errno.ENOENT, "a path that exists"),
        (errno.EROFS, "a writable dir"),
    ],
)
def test_a_filesystem_refusal_is_one_line_naming_the_path(monkeypatch, capsys, code, valid):
    def refused():
        raise OSError(code, os.strerror(code), "runs/" + "x" * 5000)

    monkeypatch.setattr(cli, "app", refused)
    with pytest.raises(SystemExit) as exit_:
        cli.main()
    assert exit_.value.code == 2
    line = capsys.readouterr().err
    assert line.count("\n") == 1 and line.startswith("mapush: error: ")
    assert os.strerror(code) in line and valid in line.partition("; valid: ")[2] and "cannot write" not in line
    assert "'runs/xxx" in line and "(5005 characters)" in line and len(line) < 400


def test_an_os_error_that_is_no_filesystem_refusal_still_raises(monkeypatch):
    def broken():
        raise OSError(errno.EPIPE, os.strerror(errno.EPIPE))

    monkeypatch.setattr(cli, "app", broken)
    with pytest.raises(OSError):
        cli.main()
