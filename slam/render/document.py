"""The report document of a campaign: sections (tables and notes) and figures, rendered
to Markdown and to self-contained HTML.  A kind describes its report as a
:class:`KindReport` value; this module knows nothing of any particular kind."""

from __future__ import annotations

import base64
import html
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slam.render.tables import html_table, html_text, markdown_table, paper_rows
from slam.results import CampaignResult

Figure = Callable[[CampaignResult, Path], None]
"""Draws one figure of a campaign into a file."""


def _title(summary: dict[str, Any], world: Any, what: str) -> tuple[str, str, str]:
    name = summary.get("world", getattr(world, "name", "?"))
    description = getattr(world, "description", "")
    facts = (f"{summary.get('runs', '?')} Monte Carlo runs, seed {summary.get('seed', '?')}, "
             f"world kind `{summary.get('kind', getattr(world, 'kind', '?'))}`")
    return f"{name}: {what}", description, facts


@dataclass(frozen=True)
class Section:
    """One part of a report: a heading, optionally a table, optionally a paragraph."""

    title: str
    header: Sequence[str] | None = None
    rows: Sequence[Sequence[str]] = ()
    text: str = ""


@dataclass(frozen=True)
class KindReport:
    """How to report one world kind: what the campaign is, its sections (tables and
    notes), its figures (file name -> (draw function, caption)), its terminal table,
    and any extra files (e.g. trajectories)."""

    what: str
    sections: Callable[[dict[str, Any]], list[Section]]
    figures: Callable[[], dict[str, tuple[Figure, str]]]
    text_table: Callable[[dict[str, Any]], str]
    extra_files: Callable[[CampaignResult, Path], list[str]] = lambda result, out: []


def captioned(writers: dict[str, Figure], captions: dict[str, str]
              ) -> dict[str, tuple[Figure, str]]:
    """File name -> (function drawing it, caption), for :attr:`KindReport.figures`."""
    return {name: (fn, captions[name]) for name, fn in writers.items()}


def paper_ranges_section(summary: dict[str, Any], title: str, ours: str) -> Section:
    """The paper's quoted error ranges next to ours (:func:`~slam.render.tables.paper_rows`),
    or a note that the world quotes none; ``ours`` says how our ranges were taken."""
    header, rows = paper_rows(summary)
    if not rows:
        return Section(title, text="The world file quotes no error ranges from a paper.")
    source = (summary.get("paper") or {}).get("source")
    note = ("The paper's ranges were read off its figures, so they are approximate"
            + (f" (source: {source})." if source else ".") + f" {ours}")
    return Section(title, header, rows, note)


def report_markdown(result: CampaignResult, kr: KindReport, figures: Sequence[str]) -> str:
    """``report.md``: title, sections and the figures (as relative image links)."""
    s = result.summary
    title, description, facts = _title(s, result.world, kr.what)
    parts = [f"# {title}", ""]
    if description:
        parts += [description, ""]
    parts += [facts + ".", ""]
    for sec in kr.sections(s):
        parts += [f"## {sec.title}", ""]
        if sec.header is not None:
            parts += [markdown_table(sec.header, sec.rows), ""]
        if sec.text:
            parts += [sec.text, ""]
    captions = {n: c for n, (_, c) in kr.figures().items()}
    if figures:
        parts += ["## Figures", ""]
        for f in figures:
            parts += [f"![{f}]({f})", "", f"*{captions.get(f, f)}*", ""]
    return "\n".join(parts)


_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1150px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; }
th { background: #f2f2f2; }
td { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td:first-child { text-align: left; font-weight: 600; }
figure { margin: 1.5em 0; }
img { max-width: 100%; }
figcaption { color: #555; font-size: 0.9em; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def report_html(result: CampaignResult, kr: KindReport, figures: dict[str, bytes]) -> str:
    """``report.html``: the report with figures embedded as base64 PNG data URIs."""
    s = result.summary
    title, description, facts = _title(s, result.world, kr.what)
    e = html.escape
    out = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
           f"<title>{e(title)}</title>", f"<style>{_CSS}</style>", "</head>", "<body>",
           f"<h1>{e(title)}</h1>"]
    if description:
        out.append(f"<p>{e(description)}</p>")
    out.append(f"<p>{html_text(facts)}.</p>")
    for sec in kr.sections(s):
        out.append(f"<h2>{e(sec.title)}</h2>")
        if sec.header is not None:
            out.append(html_table(sec.header, sec.rows))
        if sec.text:
            out.append(f"<p>{html_text(sec.text)}</p>")
    captions = {n: c for n, (_, c) in kr.figures().items()}
    if figures:
        out.append("<h2>Figures</h2>")
        for name, png in figures.items():
            data = base64.b64encode(png).decode("ascii")
            out += ["<figure>", f'<img alt="{e(name)}" src="data:image/png;base64,{data}">',
                    f"<figcaption>{e(captions.get(name, name))}</figcaption>",
                    "</figure>"]
    out += ["</body>", "</html>", ""]
    return "\n".join(out)
