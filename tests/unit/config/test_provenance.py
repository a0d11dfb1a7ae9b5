"""Which mapush made a file: its version and a hash of its installed code and configs (mapush.provenance)."""

from __future__ import annotations

import shutil

import mapush
from mapush import provenance
from mapush.provenance import files_hash, hash_differs, package_hash, run_made_by_other_code


def fake_package(root):
    (root / "conf" / "task").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "conf" / "task" / "cuboid.yaml").write_text("name: cuboid\n")
    return root


def test_the_hash_follows_code_and_configs_not_where_they_lie_or_other_files(tmp_path):
    here = fake_package(tmp_path / "a" / "mapush")
    there = shutil.copytree(here, tmp_path / "b" / "mapush")
    assert files_hash(here) == files_hash(there)  # a clone and a wheel's site-packages copy agree
    before = files_hash(here)
    (here / "__pycache__").mkdir()
    (here / "__pycache__" / "x.py").write_text("cached")
    (here / "policies").mkdir()
    (here / "policies" / "config.yaml").write_text("a shipped run's config: not code")
    assert files_hash(here) == before
    (here / "conf" / "task" / "cuboid.yaml").write_text("name: cuboid\nsize: 2\n")
    assert files_hash(here) != before
    changed = files_hash(here)
    (here / "new.py").write_text("")
    assert files_hash(here) != changed


def test_the_running_package_is_hashed_once_a_process(monkeypatch):
    first = package_hash()
    monkeypatch.setattr(provenance, "files_hash", lambda: "recomputed")
    assert package_hash() == first
    assert len(first) == 64


def test_provenance_names_the_version_and_the_hash():
    assert provenance.provenance() == {"mapush_version": mapush.__version__, "package_hash": package_hash()}


def test_only_a_recorded_other_hash_warns_in_one_line(tmp_path):
    assert hash_differs({"commit": None}) is None  # a run made before the hash was recorded: nothing said
    assert hash_differs({"package_hash": package_hash()}) is None
    warning = hash_differs({"package_hash": "0" * 64, "mapush_version": "0.0.9"})
    assert warning.startswith("warning: ") and "\n" not in warning and "0.0.9" in warning
    assert run_made_by_other_code(tmp_path) is None  # no meta.json: other commands say so
    (tmp_path / "meta.json").write_text("[not a dict")
    assert run_made_by_other_code(tmp_path) is None
