"""What README.md and docs/ state is checked here, so that they cannot go stale: the
length, the commands (and ``.ci/run``'s copy of them), the worlds table against the
registry, the figure lists against each kind's figure specs, the results table's layout
against a golden campaign rendered by today's code, the library snippet (it runs), and
every bundled world named somewhere."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from slam.registry import KINDS, list_worlds

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
DOCS = sorted(p for p in (ROOT / "docs").glob("**/*.md") if "_build" not in p.parts)
GOLDEN = ROOT / "tests" / "golden" / "bailey-joint.summary.json"


def section(title: str, text: str = README) -> str:
    """The text of the ``## title`` section (up to the next ``## ``)."""
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:] if end < 0 else text[start:end]


def code_blocks(text: str) -> list[str]:
    """The indented (4-space) code blocks of a Markdown text, dedented."""
    blocks, cur = [], []
    for line in text.split("\n") + [""]:
        if line.startswith("    ") or (cur and not line.strip()):
            cur.append(line[4:])
        elif cur:
            blocks.append("\n".join(cur).strip("\n"))
            cur = []
    return [b for b in blocks if b]


def table_rows(text: str) -> list[list[str]]:
    """The body rows of the Markdown table(s) in ``text``, cells stripped."""
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in text.split("\n") if line.startswith("|")]
    return [r for r in rows if not all(set(c) <= set("-:") for c in r)][1:]


def test_the_readme_is_at_most_250_lines() -> None:
    assert len(README.split("\n")) - 1 <= 250


def test_ci_runs_the_readme_commands_verbatim() -> None:
    """.ci/run installs the project exactly as the README's test command says, and builds
    the docs as its docs command says."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    commands = code_blocks(section("The two commands"))
    assert len(commands) == 3
    run, test, docs = commands
    assert run.endswith(".venv/bin/slam run") and "pytest" in test and "sphinx-build -W" in docs
    ci_lines = [line.strip() for line in ci.split("\n")]
    assert test in ci_lines
    assert any(line.startswith(docs) for line in ci_lines)


def test_the_worlds_table_is_the_registrys() -> None:
    rows = table_rows(section("Bundled worlds"))
    listed = [(n.strip("`"), k, d) for n, k, d in rows]
    assert listed == list_worlds(), "README's worlds table differs from `slam worlds`"


def test_every_bundled_world_is_named_in_the_readme_or_the_docs() -> None:
    text = README + "".join(p.read_text(encoding="utf-8") for p in DOCS)
    missing = [n for n, _, _ in list_worlds() if f"`{n}`" not in text]
    assert missing == []


def test_the_figure_lists_are_the_kinds_figure_specs() -> None:
    rows = {kind: re.findall(r"`([^`]+)`", figs)
            for kind, figs in table_rows(section("Figures"))}
    specs = {name: list(kind.report.figures()) for name, kind in KINDS.items()}
    assert rows == specs, "README's figure table differs from the kinds' figure specs"


def test_each_kind_page_lists_that_kinds_bundled_worlds() -> None:
    pages = {}
    for page in (ROOT / "docs" / "kinds").glob("*.md"):
        text = page.read_text(encoding="utf-8")
        kind = re.match(r"# .*\(`([^`]+)`\)", text).group(1)
        found = re.search(r"^Bundled worlds: (.*)\(`slam run WORLD`\)", text, re.M)
        pages[kind] = re.findall(r"`([^`]+)`", found.group(1)) if found else []
    for name, kind, _ in list_worlds():
        assert name in pages.get(kind, []), f"docs/kinds page of {kind} does not list {name}"
    assert set(KINDS) - {"recorded-log"} <= set(pages)


def test_the_results_table_has_the_layout_the_code_prints() -> None:
    """The pasted table of `slam run` (50 runs) has the header, the estimator rows and the
    column count that today's code prints for a golden bailey campaign (its numbers come
    from the 50-run campaign and are not re-run here)."""
    golden = json.loads(GOLDEN.read_text(encoding="utf-8"))
    printed = KINDS["planar-slam"].report.text_table(golden).split("\n")
    dashes = next(i for i, line in enumerate(printed) if line.startswith("---------"))
    blocks = code_blocks(section("What `slam run` prints"))
    pasted = blocks[0].split("\n")
    head = [line.split() for line in pasted[: dashes + 1]]
    assert head == [line.split() for line in printed[: dashes + 1]], "stale header"
    rows = printed[dashes + 1: dashes + 1 + len(golden["filters"]) + 2]
    ours = pasted[dashes + 1: dashes + 1 + len(rows)]
    assert [r.split()[0] for r in ours] == [r.split()[0] for r in rows], "stale rows"
    assert [len(r.split()) for r in ours] == [len(r.split()) for r in rows], "stale columns"
    assert re.search(r"^50 runs x 4 filters \+ baselines( \(joint mode\))? in [\d.]+ s on "
                     r"\d local workers?; results in out/bailey/$", "\n".join(blocks), re.M)


def test_the_library_snippet_runs() -> None:
    snippet = code_blocks(section("The library in ten lines"))[0]
    assert len(snippet.split("\n")) <= 12
    done = subprocess.run([sys.executable, "-c", snippet], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("page", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_docs_pages_point_into_the_repository(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"SCENARIOS\.md|KIND-CHECKLIST|/work/|seed 00\d", text)
