"""Sphinx extension: write the generated pages before the sources are read.

``docs/generated/worlds.md`` is the world-file reference (:mod:`slam.render.reference`),
``docs/generated/figures-<kind>.md`` each kind's figure list from its report's figure
specs (file name and caption), ``docs/generated/worlds-list.md`` the bundled worlds as
``slam worlds`` lists them.  Nothing under ``docs/generated/`` is written by hand.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sphinx.application import Sphinx


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def figure_list(kind: str) -> str:
    """A kind's figures as a Markdown table (name, caption) from its figure specs."""
    from slam.registry import KINDS

    rows = ["| file | what it shows |", "|---|---|"]
    for name, (_, caption) in KINDS[kind].report.figures().items():
        rows.append(f"| `{name}` | {' '.join(caption.split()).replace('|', '/')} |")
    return "\n".join(rows) + "\n"


def worlds_list() -> str:
    """The bundled worlds (``slam worlds``) as a Markdown table."""
    from slam.registry import list_worlds

    rows = ["| world | kind | description |", "|---|---|---|"]
    rows += [f"| `{n}` | {k} | {d.replace('|', '/')} |" for n, k, d in list_worlds()]
    return "\n".join(rows) + "\n"


def generate(app: Sphinx) -> None:
    from slam.registry import KINDS
    from slam.render.reference import markdown

    out = Path(app.srcdir) / "generated"
    _write(out / "worlds.md", markdown())
    _write(out / "worlds-list.md", worlds_list())
    for kind in KINDS:
        _write(out / f"figures-{kind}.md", figure_list(kind))


def drop_missing_results(app: Sphinx, docname: str, source: list[str]) -> None:
    """``docs/results.md`` is written by the results job: the index's toctree names it
    only when the file exists (else the build, with warnings as errors, would fail)."""
    if docname == "index" and not (Path(app.srcdir) / "results.md").exists():
        source[0] = "\n".join(line for line in source[0].split("\n") if line.strip() != "results")


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("builder-inited", generate)
    app.connect("source-read", drop_missing_results)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
