"""The docs live in the repo and say each thing once: short entry pages, no citation of a document outside the
repo, links and backticked paths that resolve, and dated notes that say whether they were adopted."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from paths import REPO

ROOT = REPO
THIS = Path(__file__).resolve().relative_to(ROOT).as_posix()

README_MAX_LINES = 250
RESULTS_README_MAX_LINES = 400
CITED_DOC = re.compile(r"(?<![\w.-])([A-Za-z0-9][\w.-]*\.md)\b")
"""A Markdown document named in a file: it must be one the repo holds (a clone cannot follow any other)."""
NUMBERED_SECTION = re.compile(r"\b[a-z]+ section \d")
"""`<document> section N`: a numbered section of a document that is not in the repo (the repo's docs have none)."""
PLACEHOLDER_DOCS = {"OUT.md"}
"""Names that stand for a file the user chooses (`--out OUT` writes OUT.md)."""
PATH_PREFIXES = ("mapush/", "tools/", "docs/", "results/", "tests/", ".ci/")
PLACEHOLDERS = ("*", "<", "{", "...", "NAME", "RUN")
STATUSES = ("not adopted", "adopted", "superseded")

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
BACKTICKED = re.compile(r"`([^`\n]+)`")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.DOTALL | re.MULTILINE)


def tracked_files() -> list[str]:
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    return [name for name in out.stdout.decode().split("\0") if name]


def doc_files() -> list[Path]:
    """README.md, CHANGELOG.md and every Markdown file under docs/ and results/ (tracked or new)."""
    files = [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    for folder in ("docs", "results"):
        files += sorted((ROOT / folder).rglob("*.md"))
    return files


def line_count(path: Path) -> int:
    return len(path.read_text().splitlines())


def relative_links(text: str) -> list[str]:
    """The targets of `[..](target)` links that point into the repo, anchors cut off."""
    targets = []
    for target in LINK.findall(FENCE.sub("", text)):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # http(s), mailto, ... and in-page anchors
        targets.append(target.split("#", 1)[0])
    return targets


def repo_paths(text: str) -> list[str]:
    """Backticked repo paths outside code blocks, without wildcards or placeholders."""
    paths = []
    for span in BACKTICKED.findall(FENCE.sub("", text)):
        word = span.strip()
        if " " in word or not word.startswith(PATH_PREFIXES) or any(p in word for p in PLACEHOLDERS):
            continue
        paths.append(word.split("::", 1)[0].rstrip(".,;:"))  # a pytest node id names its file
    return paths


def test_the_readme_is_short():
    assert line_count(ROOT / "README.md") <= README_MAX_LINES


def test_the_results_readme_is_short():
    assert line_count(ROOT / "results" / "README.md") <= RESULTS_README_MAX_LINES


def test_the_readme_keeps_the_two_commands_ci_runs():
    text = (ROOT / "README.md").read_text()
    assert "bash tools/setup.sh && .venv/bin/mapush train\n" in text
    assert 'EXTRAS=test,ray bash tools/setup.sh && .venv/bin/python -m pytest -m "" -n auto --durations=15\n' in text


def test_no_tracked_file_cites_a_document_outside_the_repo():
    offenders, held = [], held_documents()  # once: git ls-files for each of a thousand files took half a minute
    for name in tracked_files():
        if name == THIS:
            continue
        path = ROOT / name
        if not path.is_file():
            continue  # deleted in the worktree, not yet in the index
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue  # binary
        offenders += [f"{name}: {doc}" for doc in foreign_citations(text, held)]
    assert not offenders, offenders


def held_documents() -> set[str]:
    """The names of the documents the repo holds (tracked or new)."""
    return {Path(name).name for name in tracked_files() if name.endswith(".md")} | {p.name for p in doc_files()}


def foreign_citations(text: str, held: set[str] | None = None) -> list[str]:
    """The documents `text` cites that the repo does not hold (`held`, by default `held_documents()`), and numbered
    sections of unnamed documents."""
    held = held_documents() if held is None else held
    cited = {doc for doc in CITED_DOC.findall(text) if doc not in held | PLACEHOLDER_DOCS}
    return sorted(cited) + NUMBERED_SECTION.findall(text)


@pytest.mark.parametrize("doc", doc_files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_resolves(doc: Path):
    missing = [t for t in relative_links(doc.read_text()) if t and not (doc.parent / t).exists()]
    assert not missing, missing


@pytest.mark.parametrize("doc", doc_files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_backticked_repo_path_exists(doc: Path):
    missing = [p for p in repo_paths(doc.read_text()) if not (ROOT / p).exists()]
    assert not missing, missing


def test_the_docs_the_readme_names_exist():
    for name in ("design", "experiments", "fidelity", "performance", "reproducibility"):
        assert (ROOT / "docs" / f"{name}.md").is_file(), name
    assert sorted((ROOT / "docs" / "notes").glob("*.md")), "docs/notes/ holds no note"


@pytest.mark.parametrize("note", sorted((ROOT / "docs" / "notes").glob("*.md")), ids=lambda p: p.name)
def test_every_note_opens_with_its_status(note: Path):
    assert re.match(r"^\d{4}-\d{2}-\d{2}-[a-z0-9-]+\.md$", note.name), "name a note YYYY-MM-DD-topic.md"
    lines = [line for line in note.read_text().splitlines() if line.strip()]
    assert lines and lines[0].startswith("# "), "a note starts with its title"
    assert len(lines) > 1 and lines[1].startswith("Status:"), "the line after the title is its status"
    assert any(status in lines[1].lower() for status in STATUSES), lines[1]


def test_the_checks_catch_what_they_should():
    """The helpers flag a broken link, a missing path and a foreign citation, and skip what they should skip."""
    text = "[a](missing/file.md) [b](https://x.org) [c](#anchor) `mapush/nope.py` `tools/*.py` `runs/<run>`\n"
    text += "```bash\n[d](in/code.md) `mapush/in_code.py`\n```\n"
    assert relative_links(text) == ["missing/file.md"]
    assert repo_paths(text) == ["mapush/nope.py"]
    assert foreign_citations("see notes-elsewhere.md 1.1 and design.md") == ["notes-elsewhere.md"]
    assert foreign_citations("as spec section 6 says") == ["spec section 6"]


FIGURE = re.compile(r"(?<![\w.])\d+(?:\.\d+)? ± \d+(?:\.\d+)?(?![.\d])|(?<![\w.])(?<!± )\d+\.\d %")
"""A figure a command generates: a cell `x ± y` (also written `x +- y`) or a share `NN.N %` (not the std of a cell)."""
PLUS_MINUS = re.compile(r" (?:±|\+-) ")
FIGURE_DOCS = ("README.md", "results/README.md", "docs/*.md")
"""The docs whose figures must be generated ones: docs/notes/ are dated history and keep what they measured."""
GENERATED = (".md", ".csv", ".json")


CITED = "mapush/report/paper.yaml"
"""The numbers of other work (the paper's, the original's stored results), cited once: a doc may quote them too."""


def generated_text() -> str:
    """Every committed generated file under results/ (tables, sidecars, records), `±` written one way, and the
    cited numbers of other work as shares (`72.3` in paper.yaml holds `72.3 %`)."""
    names = [n for n in tracked_files() if n.startswith("results/") and n.endswith(GENERATED)]
    texts = [(ROOT / n).read_text() for n in names if Path(n).name != "README.md" and (ROOT / n).is_file()]
    cited = [f"{number} %" for number in re.findall(r"(?<![\w.])\d+\.\d(?![\d])", (ROOT / CITED).read_text())]
    return PLUS_MINUS.sub(" ± ", "\n".join([*texts, *cited]))


def unsourced_figures(doc: str, text: str, source: str) -> list[str]:
    """`doc:line: figure` for each figure of `text` that `source` does not hold: a cell verbatim; a share as a
    share or as a cell's mean (`60.0 %` is held by `60.0 ± 6.0`)."""
    missing = []
    for number, line in enumerate(text.splitlines(), 1):
        for figure in FIGURE.findall(PLUS_MINUS.sub(" ± ", line)):
            held = figure in source or (figure.endswith(" %") and f"{figure[:-2]} ±" in source)
            if not held:
                missing.append(f"{doc}:{number}: {figure}")
    return missing


def figure_docs() -> list[Path]:
    return sorted({path for pattern in FIGURE_DOCS for path in ROOT.glob(pattern)})


def test_the_docs_quote_only_figures_the_committed_results_hold():
    """No figure a command generates is typed into a doc by hand: a doc that quotes one quotes a generated file under
    results/ verbatim (and links it); a dated measurement no such file holds belongs in docs/notes/."""
    source = generated_text()
    missing = []
    for doc in figure_docs():
        missing += unsourced_figures(doc.relative_to(ROOT).as_posix(), doc.read_text(), source)
    assert not missing, "figures no committed file under results/ holds:\n" + "\n".join(missing)


def test_the_figure_check_catches_a_made_up_figure():
    """A doc quoting a cell or share the results hold passes; a made-up one is named with its doc and line."""
    source = PLUS_MINUS.sub(" ± ", "| Cuboid | 62.0 ± 10.0 † | 74.0 +- 1.0 % |\n- Cuboid: SA 84.0 % is at or above")
    quoted = "Ours gets 62.0 ± 10.0 and 74.0 ± 1.0 %, SA 84.0 % and 62.0 %.\nIt took 3.9 minutes.\n"
    assert unsourced_figures("doc.md", quoted, source) == []
    made_up = quoted + "Ours gets 53.5 ± 21.0 and 12.3 +- 4.5 %; SA 99.9 % at 2 kg, and 100.0 %.\n"
    assert unsourced_figures("doc.md", made_up, source) == [
        "doc.md:3: 53.5 ± 21.0",
        "doc.md:3: 12.3 ± 4.5",
        "doc.md:3: 99.9 %",
        "doc.md:3: 100.0 %",
    ]
    checked = [path.relative_to(ROOT).as_posix() for path in figure_docs()]
    assert {"README.md", "results/README.md", "docs/experiments.md"} <= set(checked)
    assert not any(name.startswith("docs/notes/") for name in checked)
    assert "53.5 ± 21.0" in generated_text()  # a cell of results/team_quick.md: the committed results are read
