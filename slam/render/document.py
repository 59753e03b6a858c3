"""The report document of a campaign: sections (tables and notes), links to the folder's
other files, figures and the provenance block, rendered to Markdown and to HTML whose
figures are embedded (its only links are relative ones to files in the same folder).  A
kind describes its report as a :class:`KindReport` value; this module knows nothing of
any particular kind."""

from __future__ import annotations

import base64
import html
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

from slam.render.provenance import provenance_line, provenance_rows
from slam.render.tables import html_table, html_text, markdown_table, paper_rows, table_at
from slam.results import CampaignResult

Figure = Callable[[CampaignResult, Path], None]
"""Draws one figure of a campaign into a file."""


def _title(summary: dict[str, Any], world: Any, what: str) -> tuple[str, str, str]:
    name = summary.get("world", getattr(world, "name", "?"))
    description = getattr(world, "description", "")
    runs = summary.get("runs")
    seed = f", seed {summary['seed']}" if "seed" in summary else ""
    facts = ("" if runs is None else f"{runs} Monte Carlo run{'' if runs == 1 else 's'}{seed}, ")
    facts += f"world kind `{summary.get('kind', getattr(world, 'kind', '?'))}`"
    return f"{name}: {what}", description, facts


@dataclass(frozen=True)
class Section:
    """One part of a report: a heading, optionally a table, optionally a paragraph."""

    title: str
    header: Sequence[str] | None = None
    rows: Sequence[Sequence[str]] = ()
    text: str = ""
    key_value: bool = False
    """A two-column table of items and texts (left-aligned, wrapping) rather than numbers."""


Link = tuple[str, str]
"""A file of the report folder the report links to: (file name, what it holds)."""


@dataclass(frozen=True)
class KindReport:
    """How to report one world kind: what the campaign is, its sections (tables and
    notes), its figures (file name -> (draw function, caption); see
    :func:`slam.render.figures.figure_table`), its terminal table, any extra files (e.g.
    trajectories) and ``links``: the extra files the report links to (the names
    ``extra_files`` writes, known before it runs)."""

    what: str
    sections: Callable[[dict[str, Any]], list[Section]]
    figures: Callable[[], dict[str, tuple[Figure, str]]]
    text_table: Callable[[dict[str, Any]], str]
    extra_files: Callable[[CampaignResult, Path], list[str]] = lambda result, out: []
    links: Callable[[CampaignResult], list[Link]] = lambda result: []

    def markdown(self, summary: dict[str, Any]) -> str:
        """Markdown of the kind's sections alone (:func:`sections_markdown`): its tables
        for the README and the tests."""
        return sections_markdown(self.sections(summary))


def report_links(result: CampaignResult, kr: KindReport) -> list[Link]:
    """Every file the report links to: the summary, the Markdown report and the kind's."""
    return [("summary.json", "the campaign's numbers (strict JSON)"),
            ("report.md", "this report in Markdown"), *kr.links(result)]


def _provenance_sections(summary: dict[str, Any]) -> list[Section]:
    rows = provenance_rows(summary.get("provenance"))
    return [Section("Provenance", ("item", "value"), rows, key_value=True)] if rows else []


def paper_ranges_section(summary: dict[str, Any], title: str, ours: str) -> Section:
    """The paper's quoted error ranges next to ours (:func:`~slam.render.tables.paper_rows`),
    or a note that the world quotes none; ``ours`` says how our ranges were taken."""
    header, rows = paper_rows(summary)
    if not rows:
        return Section(title, text="The world file quotes no error ranges from a paper.")
    source = table_at(summary, "paper").get("source")
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
    line = provenance_line(s.get("provenance"))
    if line:
        parts += [line, ""]
    for sec in kr.sections(s):
        parts += _markdown_section(sec)
    parts += ["## Files", ""]
    parts += [f"- [`{name}`]({name}): {what}" for name, what in report_links(result, kr)]
    parts.append("")
    if figures:
        captions = {n: c for n, (_, c) in kr.figures().items()}
        parts += ["## Figures", ""]
        for f in figures:
            parts += [f"![{f}]({f})", "", f"*{captions.get(f, f)}*", ""]
    for sec in _provenance_sections(s):
        parts += _markdown_section(sec)
    return "\n".join(parts)


def sections_markdown(sections: Sequence[Section], level: int = 3) -> str:
    """Markdown of ``sections`` alone (title, table, text), headings at ``level``: a
    kind's tables for the README and the tests."""
    return "\n".join(line for sec in sections for line in _markdown_section(sec, level))


def _markdown_section(sec: Section, level: int = 2) -> list[str]:
    parts = [f"{'#' * level} {sec.title}", ""]
    if sec.header is not None:
        parts += [markdown_table(sec.header, sec.rows), ""]
    if sec.text:
        parts += [sec.text, ""]
    return parts


_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1280px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; display: block;
        max-width: 100%; overflow-x: auto; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; }
th { background: #f2f2f2; }
td { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td:first-child { text-align: left; font-weight: 600; }
figure { margin: 1.5em 0; }
img { max-width: 100%; }
figcaption { color: #555; font-size: 0.9em; }
code { background: #f4f4f4; padding: 0 0.2em; }
.provenance { color: #555; font-size: 0.9em; }
table.kv td { text-align: left; white-space: normal; overflow-wrap: anywhere; }
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
    line = provenance_line(s.get("provenance"))
    if line:
        out.append(f'<p class="provenance">{html_text(line)}</p>')
    for sec in kr.sections(s):
        out += _html_section(sec)
    out.append("<h2>Files</h2>")
    out.append("<ul>" + "".join(f'<li><a href="{e(quote(name))}"><code>{e(name)}</code></a>: '
                                f"{e(what)}</li>" for name, what in report_links(result, kr))
               + "</ul>")
    if figures:
        captions = {n: c for n, (_, c) in kr.figures().items()}
        out.append("<h2>Figures</h2>")
        for name, png in figures.items():
            data = base64.b64encode(png).decode("ascii")
            out += ["<figure>", f'<img alt="{e(name)}" src="data:image/png;base64,{data}">',
                    f"<figcaption>{e(captions.get(name, name))}</figcaption>",
                    "</figure>"]
    for sec in _provenance_sections(s):
        out += _html_section(sec)
    out += ["</body>", "</html>", ""]
    return "\n".join(out)


def _html_section(sec: Section) -> list[str]:
    out = [f"<h2>{html.escape(sec.title)}</h2>"]
    if sec.header is not None:
        out.append(html_table(sec.header, sec.rows, "kv" if sec.key_value else None))
    if sec.text:
        out.append(f"<p>{html_text(sec.text)}</p>")
    return out
