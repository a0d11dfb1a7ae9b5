"""The package's structure: layers that point one way (import-linter's contract in pyproject.toml), no cycles."""

from __future__ import annotations

import graphlib

import grimp
import pytest
from importlinter.cli import lint_imports
from paths import REPO

ROOT = REPO


def test_the_layers_contract_is_kept(capsys):
    code = lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True, no_logo=True)
    assert code == 0, capsys.readouterr().out


def assert_acyclic(package: str) -> None:
    """Every import of every module of `package` (those inside functions included) as a graph; a cycle raises
    graphlib.CycleError naming it."""
    graph = grimp.build_graph(package, cache_dir=None)
    edges = {m: graph.find_modules_directly_imported_by(m) for m in graph.modules}
    graphlib.TopologicalSorter(edges).prepare()


def test_no_module_imports_itself_back():
    assert_acyclic("mapush")


def test_a_cycle_is_caught(tmp_path, monkeypatch):
    """The check above fails on a package with a cycle (so its silence means something)."""
    pkg = tmp_path / "cyclic"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from cyclic import b\n")
    (pkg / "b.py").write_text("from cyclic import a\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(graphlib.CycleError):
        assert_acyclic("cyclic")
