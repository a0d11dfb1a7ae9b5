"""The package's structure: layers that point one way (import-linter's contract in pyproject.toml), no cycles;
modules with names of their own and of readable length; levels told apart only by their registry; a command line
that imports few of the package's modules."""

from __future__ import annotations

import ast
import graphlib
import re
from collections import Counter

import grimp
import pytest
from importlinter.cli import lint_imports
from paths import REPO

ROOT = REPO
MAX_MODULE_LINES = 350


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


def test_every_module_has_its_own_name_and_fits_on_a_few_screens():
    # a newcomer finds a module by its name alone, and reads it whole
    modules = [p for p in (REPO / "mapush").rglob("*.py") if "__pycache__" not in p.parts]
    names = Counter(p.name for p in modules if p.name not in ("__init__.py", "__main__.py"))
    assert [name for name, count in names.items() if count > 1] == []
    long = {str(p.relative_to(REPO)): n for p in modules if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}


def test_no_code_outside_the_level_registry_asks_which_level_it_holds():
    pattern = re.compile(r"""\blevel(?:["'\]\[.]{1,4}name["'\]]{0,2}|_name)?\s*[!=]=\s*["']""")
    found = [
        f"{p.relative_to(REPO)}:{i}"
        for p in (REPO / "mapush").rglob("*.py")
        if p.name != "levels.py"
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if pattern.search(line)
    ]
    assert found == []


def test_what_the_archive_memo_ignores_is_what_the_experiments_cannot_import():
    """`archive.NOT_COMPOSING` leaves out of the memo's key only modules in layers above the experiments' or beside
    it (pyproject.toml's contract), so no change it ignores can change what a job composes; and every module the
    experiments import is in the key."""
    import tomllib

    from mapush.experiments.archive import NOT_COMPOSING

    layers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"][0]["layers"]
    rank = {m.strip(): k for k, layer in enumerate(layers) for m in layer.split("|")}
    own = rank["mapush.experiments"]
    for part in NOT_COMPOSING:
        module = "mapush." + part.removesuffix(".py").replace("/", ".")
        assert rank[module] <= own and module != "mapush.experiments", module
    graph = grimp.build_graph("mapush", cache_dir=None)
    reached = graph.find_upstream_modules("mapush.experiments", as_package=True)
    ignored = ["mapush." + p.removesuffix(".py").replace("/", ".") for p in NOT_COMPOSING]
    assert not [m for m in reached if any(m == i or m.startswith(i + ".") for i in ignored)]


MAX_CLI_IMPORTS = 6
"""The top-level mapush modules and packages the command line (mapush/cli/) may import: a thin Typer surface over
`mapush.commands`, the implementations."""


def mapush_imports(source: str) -> set[str]:
    """The top-level mapush modules and packages that `source` imports anywhere (inside functions too): `cli` for
    `mapush.cli.app`, `config` for `from mapush import config`."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[1] for alias in node.names if alias.name.startswith("mapush.")}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            parts = node.module.split(".")
            if parts[0] == "mapush":
                found |= {parts[1]} if len(parts) > 1 else {alias.name for alias in node.names}
    return found


def test_the_cli_is_a_thin_surface_over_the_commands():
    files = sorted((REPO / "mapush" / "cli").glob("*.py"))
    imported = set().union(*(mapush_imports(p.read_text()) for p in files)) - {"cli"}
    assert len(imported) <= MAX_CLI_IMPORTS, sorted(imported)


def test_imports_inside_functions_count():
    """The count above sees lazy imports and each name of `from mapush import a, b` (so its silence means
    something)."""
    source = "import mapush.rundir\nfrom mapush import config, trust\ndef f():\n    from mapush.eval.rollout import x\n"
    assert mapush_imports(source) == {"rundir", "config", "trust", "eval"}


REPORT_MUST_NOT = re.compile(
    r"partition\(\"=\"\)|compose_config|apply_overrides|OverridesParser|initialize_config_dir|\bcompose\("
)
"""What composing a config or parsing an override looks like in code."""


def test_the_report_reads_typed_results_and_never_composes_a_config_or_parses_an_override():
    found = [
        f"{p.relative_to(ROOT)}:{i}"
        for p in sorted((ROOT / "mapush" / "report").rglob("*.py"))
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if REPORT_MUST_NOT.search(line)
    ]
    assert found == []
    assert REPORT_MUST_NOT.search('key, _, value = override.partition("=")')  # as the team table once did
