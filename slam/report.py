"""Reports of a planar SLAM campaign: ``summary.json``, Markdown/HTML, figures, TUM files.

:func:`write_outputs` renders a :class:`~slam.results.CampaignResult` into a fresh
temporary folder next to the output folder and only then swaps it into place, so a
failed or interrupted run leaves either the old folder or the new one, never a mix:

    summary.json   the summary dict as strict JSON (non-finite numbers become ``null``)
    report.md      title, results table, paper-vs-ours table, how to read it, figures
    report.html    the same, self-contained (figures embedded as base64 PNG)
    map.png        map, paths and landmark estimates of run 0
    errors_xy.png  x / y error vs time: run 0, its ±2σ, the Monte Carlo envelope, the paper
    nees.png       run-averaged NEES / 3 vs time against its 95 % band
    <name>.tum     run 0's trajectory of every estimator, and ``truth.tum`` (TUM format)

:func:`results_table` (Markdown) and :func:`text_table` (aligned plain text) render the
results table from a summary dict alone; the command line prints the latter.
"""

from __future__ import annotations

import base64
import html
import importlib
import json
import math
import os
import shutil
import stat
import tempfile
import uuid
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Ellipse, Patch, Rectangle  # noqa: E402
from matplotlib.ticker import FormatStrFormatter  # noqa: E402

from .results import ODOMETRY, REFERENCE, Array, CampaignResult, RunScores  # noqa: E402

DPI = 110
MISSING = "—"
SUMMARY = "summary.json"
PAPER_AXES = ("x", "y", "z")

# colours: filters take the tab10 cycle in order; the baselines and truth are fixed
_TRUTH_STYLE = {"color": "black", "lw": 1.6}
_BASELINE_STYLE = {
    ODOMETRY: {"color": "0.55", "lw": 1.0, "ls": ":"},
    REFERENCE: {"color": "#7a3b8f", "lw": 1.2, "ls": "--"},
}
_FILTER_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:brown",
                   "tab:pink", "tab:olive", "tab:cyan", "tab:purple", "tab:gray")


# --------------------------------------------------------------------------- JSON

def jsonable(obj: Any) -> Any:
    """``obj`` with numpy values made plain and non-finite floats made ``None``.

    Dicts, lists and tuples are converted recursively (dict keys become strings);
    anything else that JSON cannot hold raises :class:`TypeError`.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if obj is None or isinstance(obj, bool | int | str):
        return obj
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"cannot write {type(obj).__name__} to JSON: {obj!r}")


def summary_json(summary: dict[str, Any]) -> str:
    """The summary as strict JSON text (no NaN/Infinity tokens), key order kept."""
    return json.dumps(jsonable(summary), indent=2, sort_keys=False, allow_nan=False,
                      ensure_ascii=False) + "\n"


# --------------------------------------------------------------------------- tables

RESULT_COLUMNS = ("estimator", "pos RMSE (m)", "x range (m)", "y range (m)",
                  "heading RMSE (deg)", "landmark RMSE (m)", "ANEES [95 % band]", "NIS/dof",
                  "time/step (µs)", "diverged runs")


def _num(v: Any, fmt: str, scale: float = 1.0) -> str:
    if (v is None or isinstance(v, bool) or not isinstance(v, int | float | np.number)
            or not math.isfinite(v)):
        return MISSING
    return format(float(v) * scale, fmt)


def _interval(pair: Any, fmt: str = "+.2f") -> str:
    if not isinstance(pair, list | tuple) or len(pair) != 2:
        return MISSING
    lo, hi = (_num(v, fmt) for v in pair)
    return MISSING if MISSING in (lo, hi) else f"[{lo}, {hi}]"


def _anees_cell(entry: dict[str, Any]) -> str:
    value = _num(entry.get("anees"), ".2f")
    if value == MISSING:
        return MISSING
    band = _interval(entry.get("anees_bounds_95"), ".2f")
    return value if band == MISSING else f"{value} {band}"


def _result_row(name: str, entry: dict[str, Any]) -> list[str]:
    ranges = entry.get("pos_err_range_m") or {}
    scored, diverged = entry.get("runs_scored"), entry.get("diverged_runs")
    runs = "" if scored is None or diverged is None else f"/{scored + diverged}"
    return [
        name,
        _num(entry.get("pos_rmse_m"), ".3f"),
        _interval(ranges.get("x")),
        _interval(ranges.get("y")),
        _num(entry.get("heading_rmse_deg"), ".2f"),
        _num(entry.get("landmark_rmse_m"), ".3f"),
        _anees_cell(entry),
        _num(entry.get("nis_mean"), ".2f"),
        _num(entry.get("time_per_step_s"), ".1f", 1e6),
        MISSING if diverged is None else f"{diverged}{runs}",
    ]


def estimator_entries(summary: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """``(name, entry)`` of every estimator in table order: the filters, then the
    baselines (odometry, IMU only), then the reference smoother."""
    return [(name, entry) for group in ("filters", "baselines", "reference")
            for name, entry in (summary.get(group) or {}).items()]


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter, then the odometry baseline and the GTSAM reference."""
    return [_result_row(n, e) for n, e in estimator_entries(summary)]


def paper_rows(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the "paper vs ours" error-range table (empty if none quoted)."""
    quoted = {n: (f.get("pos_err_range_m") or {})
              for n, f in ((summary.get("paper") or {}).get("filters") or {}).items()
              if isinstance(f, dict) and f.get("pos_err_range_m")}
    axes = [a for a in PAPER_AXES if any(a in r for r in quoted.values())]
    header = ["filter"]
    for a in axes:
        header += [f"{a} paper (m)", f"{a} ours (m)"]
    rows = []
    for name, paper in quoted.items():
        ours_entry = (summary.get("filters") or {}).get(name)
        ours = (ours_entry or {}).get("pos_err_range_m") or {}
        row = [name if ours_entry is not None else f"{name} (not run)"]
        for a in axes:
            row += [_interval(paper.get(a)), _interval(ours.get(a))]
        rows.append(row)
    return header, rows


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A GitHub-flavoured Markdown table, numbers right-aligned."""
    align = ["---"] + ["---:"] * (len(header) - 1)
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def plain_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An aligned plain-text table: first column left-aligned, the others right-aligned."""
    body = [list(header)] + [list(r) for r in rows]
    widths = [max(len(r[i]) for r in body) for i in range(len(header))]

    def line(r: list[str]) -> str:
        cells = [r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:], widths[1:])]
        return "  ".join(cells).rstrip()

    rule = "  ".join("-" * w for w in widths)
    return "\n".join([line(body[0]), rule] + [line(r) for r in body[1:]])


def results_table(summary: dict[str, Any]) -> str:
    """The results table in Markdown: filters, then ``odometry`` and ``gtsam``."""
    return markdown_table(RESULT_COLUMNS, result_rows(summary))


def text_table(summary: dict[str, Any]) -> str:
    """The campaign's results table as aligned plain text (for the terminal)."""
    return kind_report(summary.get("kind", "planar-slam")).text_table(summary)


# --------------------------------------------------------------------------- report text

def _title(summary: dict[str, Any], world: Any, what: str) -> tuple[str, str, str]:
    name = summary.get("world", getattr(world, "name", "?"))
    description = getattr(world, "description", "")
    facts = (f"{summary.get('runs', '?')} Monte Carlo runs, seed {summary.get('seed', '?')}, "
             f"world kind `{summary.get('kind', getattr(world, 'kind', '?'))}`")
    return f"{name}: {what}", description, facts


def _paper_note(summary: dict[str, Any]) -> str:
    source = (summary.get("paper") or {}).get("source")
    note = ("The paper's ranges were read off its figures, so they are approximate"
            + (f" (source: {source})." if source else "."))
    return (note + " Ours are the minimum and maximum x / y error over every step of every"
            " run that did not diverge.")


HOW_TO_READ = (
    "Errors are estimate minus truth of the vehicle pose; the ranges are the extreme x / y "
    "errors over all steps and runs. ANEES is the normalised estimation error squared of "
    "the 3-dof pose, averaged over runs and steps and divided by 3: a consistent filter "
    "scores about 1, and its run-averaged NEES / 3 lies inside the bracketed 95 % band at "
    "about 95 % of the steps (above the band: overconfident; below: too cautious). "
    "NIS/dof is the same check on the measurement innovations. The `odometry` row is "
    "dead reckoning from the noisy controls alone (no landmarks): what the filters have to "
    "beat. The `gtsam` row is the batch-optimal smoother (GTSAM) on the very same "
    "measurements, using all of them at once: the gap between a filter and it is the "
    "filter's loss."
)

FIGURE_CAPTIONS = {
    "map.png": "Run 0: true landmarks, waypoints, paths and final landmark estimates "
               "(2σ ellipses).",
    "errors_xy.png": "x and y error vs time: run 0 with its ±2σ band, the Monte Carlo "
                     "envelope over all runs, and the paper's ranges (dashed).",
    "nees.png": "Run-averaged NEES / 3 vs time against the 95 % band.",
}


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
    figures: Callable[[], dict[str, tuple[Callable[[CampaignResult, Path], None], str]]]
    text_table: Callable[[dict[str, Any]], str]
    extra_files: Callable[[CampaignResult, Path], list[str]] = lambda result, out: []


def planar_sections(summary: dict[str, Any]) -> list[Section]:
    """Results, the paper's ranges next to ours, and how to read them."""
    header, rows = paper_rows(summary)
    paper = (Section("Paper vs ours: vehicle position error ranges", header, rows,
                     _paper_note(summary)) if rows else
             Section("Paper vs ours: vehicle position error ranges",
                     text="The world file quotes no error ranges from a paper."))
    return [Section("Results", RESULT_COLUMNS, result_rows(summary)), paper,
            Section("How to read this", text=HOW_TO_READ)]


def planar_figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption); looked up at call time."""
    return {name: (fn, FIGURE_CAPTIONS[name]) for name, fn in figure_writers().items()}


def kind_report(kind: str) -> KindReport:
    """The report description of a world kind (other kinds live in their own modules)."""
    if kind == "planar-slam":
        return KindReport("planar SLAM campaign", planar_sections, planar_figures,
                          lambda s: plain_table(RESULT_COLUMNS, result_rows(s)),
                          write_tum_files)
    module = {"attitude": "slam.attitude_report", "drone-slam": "slam.drone_report"}.get(kind)
    if module is None:
        raise ValueError(f"no report for world kind {kind!r}")
    return importlib.import_module(module).REPORT


def report_markdown(result: CampaignResult, figures: Sequence[str]) -> str:
    """``report.md``: title, sections and the figures (as relative image links)."""
    s = result.summary
    kr = kind_report(s.get("kind", "planar-slam"))
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


def html_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An HTML table, cells escaped."""
    e = html.escape
    head = "".join(f"<th>{e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>\n" for r in rows)
    return f"<table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}</tbody>\n</table>"


def _html_text(text: str) -> str:
    """Escape text, turning Markdown `code` spans into <code>."""
    parts = html.escape(text).split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


def report_html(result: CampaignResult, figures: dict[str, bytes]) -> str:
    """``report.html``: the report with figures embedded as base64 PNG data URIs."""
    s = result.summary
    kr = kind_report(s.get("kind", "planar-slam"))
    title, description, facts = _title(s, result.world, kr.what)
    e = html.escape
    out = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
           f"<title>{e(title)}</title>", f"<style>{_CSS}</style>", "</head>", "<body>",
           f"<h1>{e(title)}</h1>"]
    if description:
        out.append(f"<p>{e(description)}</p>")
    out.append(f"<p>{_html_text(facts)}.</p>")
    for sec in kr.sections(s):
        out.append(f"<h2>{e(sec.title)}</h2>")
        if sec.header is not None:
            out.append(html_table(sec.header, sec.rows))
        if sec.text:
            out.append(f"<p>{_html_text(sec.text)}</p>")
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


# --------------------------------------------------------------------------- figures

def filter_names(result: CampaignResult) -> list[str]:
    """The campaign's filters, in summary order."""
    return list((result.summary.get("filters") or {}).keys())


def estimator_colours(result: CampaignResult) -> dict[str, str]:
    """One colour per filter (tab10 order) plus the baselines' fixed colours."""
    out = {n: _FILTER_COLOURS[i % len(_FILTER_COLOURS)]
           for i, n in enumerate(filter_names(result))}
    out.update({n: st["color"] for n, st in _BASELINE_STYLE.items()})
    return out


def _run0(result: CampaignResult):
    first = result.outcomes[0]
    if first.truth is None or first.times is None or not first.tracks:
        raise ValueError("run 0 of the campaign kept no tracks: nothing to plot")
    return first


def _good_scores(result: CampaignResult, name: str) -> list[RunScores]:
    return [o.scores[name] for o in result.outcomes
            if name in o.scores and not o.scores[name].diverged]


def _save(fig: plt.Figure, path: Path) -> None:
    try:
        fig.savefig(path, dpi=DPI)
    finally:
        plt.close(fig)


def covariance_ellipse(mean: Array, cov: Array, n_sigma: float = 2.0, **kw) -> Ellipse | None:
    """The ``n_sigma`` ellipse of a 2-D Gaussian, or None if ``cov`` is unusable."""
    if not (np.all(np.isfinite(cov)) and np.all(np.isfinite(mean))):
        return None
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    if w[0] < 0.0:
        return None
    angle = math.degrees(math.atan2(v[1, 1], v[0, 1]))
    return Ellipse(tuple(mean), 2 * n_sigma * math.sqrt(w[1]), 2 * n_sigma * math.sqrt(w[0]),
                   angle=angle, **kw)


def _landmark_estimators(result: CampaignResult) -> list[str]:
    """Run 0's estimators that estimate landmarks: filters, then the smoother."""
    first = result.outcomes[0]
    return [n for n in [*filter_names(result), REFERENCE]
            if n in first.tracks and len(first.tracks[n].landmarks)]


def _draw_landmark_estimates(ax: plt.Axes, result: CampaignResult, names: Sequence[str],
                             colours: dict[str, str]) -> None:
    """Each estimator's final landmark means (+) and their 2σ ellipses."""
    first = result.outcomes[0]
    for name in names:
        track = first.tracks[name]
        for mean, cov in zip(track.landmarks, track.landmark_cov):
            ell = covariance_ellipse(mean, cov, fc="none", ec=colours[name], lw=1.0, zorder=5)
            if ell is not None:
                ax.add_patch(ell)
        ax.plot(track.landmarks[:, 0], track.landmarks[:, 1], "+", color=colours[name],
                ms=8, mew=1.2, zorder=6)


def _most_uncertain_landmark(result: CampaignResult, names: Sequence[str]) -> int | None:
    """Id of the landmark with the largest 2σ ellipse over the estimators (or None)."""
    first, best, best_id = result.outcomes[0], -1.0, None
    for name in names:
        track = first.tracks[name]
        for lid, cov in zip(track.landmark_ids, track.landmark_cov):
            if lid >= 0 and np.all(np.isfinite(cov)):
                size = float(np.linalg.eigvalsh(0.5 * (cov + cov.T))[-1])
                if size > best:
                    best, best_id = size, int(lid)
    return best_id


def _zoom_half_width(result: CampaignResult, names: Sequence[str], lid: int,
                     centre: Array) -> float:
    first, half = result.outcomes[0], 0.5
    for name in names:
        track = first.tracks[name]
        for i in np.flatnonzero(track.landmark_ids == lid):
            cov = track.landmark_cov[i]
            if np.all(np.isfinite(cov)):
                half = max(half, 2.4 * math.sqrt(max(np.linalg.eigvalsh(cov)[-1], 0.0)))
            half = max(half, 1.3 * float(np.max(np.abs(track.landmarks[i] - centre))))
    return half


def plot_map(result: CampaignResult, path: Path) -> None:
    """``map.png``: the world, run 0's paths and final landmark estimates (2σ ellipses),
    and a zoom on the landmark estimated least certainly (at map scale the estimates sit
    on top of the true landmarks)."""
    first, world = _run0(result), result.world
    colours = estimator_colours(result)
    fig = plt.figure(figsize=(11.0, 7.2), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(3.0, 1.2))
    ax = fig.add_subplot(grid[:, 0])
    xmin, xmax, ymin, ymax = world.map.bounds_m
    ax.add_patch(Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False,
                           ec="0.75", lw=0.8))
    wp = world.map.waypoints
    ax.plot(wp[:, 0], wp[:, 1], "s", ms=5, mfc="none", mec="0.45", label="waypoints")
    truth = first.truth
    ax.plot(truth[:, 0], truth[:, 1], label="true path", zorder=2, **_TRUTH_STYLE)
    ax.plot(truth[0, 0], truth[0, 1], "o", color="black", ms=7, label="start", zorder=6)
    for name in [*filter_names(result), ODOMETRY, REFERENCE]:
        track = first.tracks.get(name)
        if track is None:
            continue
        style = _BASELINE_STYLE.get(name, {"color": colours[name], "lw": 0.9, "alpha": 0.9})
        label = {ODOMETRY: "odometry (dead reckoning)",
                 REFERENCE: "gtsam smoother"}.get(name, name)
        ax.plot(track.poses[:, 0], track.poses[:, 1], label=label, zorder=3, **style)
    lm_names = _landmark_estimators(result)
    _draw_landmark_estimates(ax, result, lm_names, colours)
    lm = first.true_landmarks if first.true_landmarks is not None else world.map.landmarks
    star = {"marker": "*", "ls": "none", "color": "black", "mfc": "gold", "mew": 0.8}
    ax.plot(lm[:, 0], lm[:, 1], ms=10, zorder=4, label="landmarks (true)", **star)
    pad = 0.03 * max(xmax - xmin, ymax - ymin)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{result.summary.get('world', '')}: run 0")
    ax.grid(True, lw=0.3, alpha=0.5)

    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], ls="none", marker="+", color="0.3", ms=8, mew=1.2))
    labels.append("landmark estimate\n(+, 2σ ellipse)")
    legend_ax = fig.add_subplot(grid[0, 1])
    legend_ax.axis("off")
    legend_ax.legend(handles, labels, loc="upper left", fontsize=9, frameon=False)

    lid = _most_uncertain_landmark(result, lm_names)
    if lid is not None and 0 <= lid < len(lm):
        zoom = fig.add_subplot(grid[1, 1])
        _draw_landmark_estimates(zoom, result, lm_names, colours)
        zoom.plot(*lm[lid], ms=14, zorder=4, **star)
        half = _zoom_half_width(result, lm_names, lid, lm[lid])
        zoom.set_xlim(lm[lid][0] - half, lm[lid][0] + half)
        zoom.set_ylim(lm[lid][1] - half, lm[lid][1] + half)
        zoom.set_aspect("equal")
        zoom.grid(True, lw=0.3, alpha=0.5)
        zoom.tick_params(labelsize=8)
        zoom.set_title(f"zoom: landmark {lid} (largest 2σ)", fontsize=9)
        ax.add_patch(Rectangle((lm[lid][0] - half, lm[lid][1] - half), 2 * half, 2 * half,
                               fill=False, ec="0.3", lw=0.8, zorder=8))
        ax.annotate("zoom", (lm[lid][0] + half, lm[lid][1] + half), fontsize=8,
                    color="0.3", xytext=(2, 2), textcoords="offset points")
    _save(fig, path)


def _error_envelope(scores: list[RunScores], axis: int) -> tuple[Array, Array] | None:
    if not scores:
        return None
    err = np.stack([s.err[:, axis] for s in scores])
    if not np.isfinite(err).any():
        return None
    return np.nanmin(err, axis=0), np.nanmax(err, axis=0)


def _paper_range(summary: dict[str, Any], name: str, axis: str) -> list[float] | None:
    f = ((summary.get("paper") or {}).get("filters") or {}).get(name) or {}
    r = (f.get("pos_err_range_m") or {}).get(axis)
    return list(r) if isinstance(r, list | tuple) and len(r) == 2 else None


def plot_errors_xy(result: CampaignResult, path: Path) -> None:
    """``errors_xy.png``: one row per filter, x error (left) and y error (right) vs time.

    Each panel: run 0's error, its ±2σ band (from the pose covariance), the Monte Carlo
    envelope (min / max over the runs that did not diverge), the smoother's run-0 error
    for reference, and dashed lines at the paper's range where the paper quotes one.
    """
    first = _run0(result)
    names = filter_names(result)
    colours = estimator_colours(result)
    t = first.times
    fig, axes = plt.subplots(len(names), 2, figsize=(10.5, 1.2 + 1.9 * len(names)),
                             sharex=True, sharey=True, squeeze=False, layout="constrained")
    ref = first.scores.get(REFERENCE)
    for row, name in enumerate(names):
        c = colours[name]
        track = first.tracks.get(name)
        run0 = first.scores.get(name)
        for col, axis in enumerate("xy"):
            ax = axes[row, col]
            env = _error_envelope(_good_scores(result, name), col)
            if env is not None:
                ax.fill_between(t, env[0], env[1], color=c, alpha=0.15, lw=0)
            if run0 is not None and not run0.diverged and track is not None:
                with np.errstate(invalid="ignore"):
                    sd = np.sqrt(track.pose_cov[:, col, col])
                ax.plot(t, 2 * sd, color=c, lw=0.7, ls="-", alpha=0.55)
                ax.plot(t, -2 * sd, color=c, lw=0.7, ls="-", alpha=0.55)
                ax.plot(t, run0.err[:, col], color=c, lw=1.0)
            elif col == 0:
                note = "diverged on every run" if env is None else "diverged on run 0"
                ax.text(0.01, 0.95, note, transform=ax.transAxes, va="top", fontsize=8,
                        color=c)
            if ref is not None:
                ax.plot(t, ref.err[:, col], color=_BASELINE_STYLE[REFERENCE]["color"],
                        lw=0.7, alpha=0.8)
            paper = _paper_range(result.summary, name, axis)
            if paper is not None:
                for v in paper:
                    ax.axhline(v, color=c, ls="--", lw=1.2)
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.grid(True, lw=0.3, alpha=0.5)
            ax.set_ylabel(f"{name}: {axis} error (m)", fontsize=9)
            if row == 0:
                ax.set_title(f"{axis} error", fontsize=10)
            if row == len(names) - 1:
                ax.set_xlabel("time (s)")
    legend = [
        Line2D([], [], color="0.2", lw=1.0, label="run 0 error"),
        Line2D([], [], color="0.2", lw=0.7, alpha=0.55, label="run 0 ±2σ"),
        Patch(fc="0.2", alpha=0.15, label="Monte Carlo envelope (min/max)"),
        Line2D([], [], color="0.2", ls="--", lw=1.2, label="paper's range"),
        Line2D([], [], color=_BASELINE_STYLE[REFERENCE]["color"], lw=0.7,
               label="gtsam run 0 error"),
    ]
    fig.legend(handles=legend, loc="outside lower center", fontsize=8, ncols=len(legend),
               frameon=False)
    _set_error_limits(result, axes)
    fig.suptitle(f"{result.summary.get('world', '')}: vehicle position error", fontsize=11)
    _save(fig, path)


def _set_error_limits(result: CampaignResult, axes: np.ndarray) -> None:
    """Symmetric y limits that hold the envelopes and the paper's ranges (not a
    diverged run's blow-up)."""
    lim = 0.0
    for name in filter_names(result):
        for col, axis in enumerate("xy"):
            env = _error_envelope(_good_scores(result, name), col)
            if env is not None:
                lim = max(lim, float(np.nanmax(np.abs(env))))
            paper = _paper_range(result.summary, name, axis)
            if paper is not None:
                lim = max(lim, *map(abs, paper))
    if lim > 0.0:
        axes[0, 0].set_ylim(-1.15 * lim, 1.15 * lim)


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png``: run-averaged NEES / 3 vs time per filter, with the 95 % band."""
    first = _run0(result)
    colours = estimator_colours(result)
    t = first.times
    fig, ax = plt.subplots(figsize=(10, 4.6), layout="constrained")
    bands: dict[tuple[float, float], list[str]] = {}
    for name in filter_names(result):
        scores = _good_scores(result, name)
        if not scores:
            continue
        nees = np.stack([s.nees for s in scores])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # steps with no NEES in any run
            mean = np.nanmean(nees, axis=0) / 3.0
        mean[~(mean > 0.0)] = np.nan  # log axis: drop zeros (no NEES yet)
        entry = result.summary["filters"].get(name, {})
        anees = entry.get("anees")
        label = name if anees is None else f"{name} (ANEES {anees:.2f})"
        ax.plot(t, mean, color=colours[name], lw=0.8, alpha=0.85, label=label)
        band = entry.get("anees_bounds_95")
        if band:
            bands.setdefault((float(band[0]), float(band[1])), []).append(name)
    for (lo, hi), who in bands.items():
        colour = "black" if len(bands) == 1 else colours[who[0]]
        runs = len(_good_scores(result, who[0]))
        label = f"95 % band ({runs} runs)" + ("" if len(bands) == 1 else f": {', '.join(who)}")
        ax.axhline(lo, color=colour, ls="--", lw=1.2, label=label)
        ax.axhline(hi, color=colour, ls="--", lw=1.2)
    ax.axhline(1.0, color="0.5", lw=0.6)
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.tick_params(axis="y", which="both", labelsize=8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("NEES / 3 (run average)")
    ax.set_title(f"{result.summary.get('world', '')}: pose consistency "
                 f"(a consistent filter stays near 1, inside the band)")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", fontsize=8,
               ncols=max(len(handles), 1), frameon=False)
    _save(fig, path)


def figure_writers() -> dict[str, Callable[[CampaignResult, Path], None]]:
    """File name -> function drawing it (looked up at call time)."""
    return {"map.png": plot_map, "errors_xy.png": plot_errors_xy, "nees.png": plot_nees}


# --------------------------------------------------------------------------- TUM

def tum_text(times: Array, poses: Array) -> str:
    """TUM trajectory lines ``t x y z qx qy qz qw`` for planar poses ``[x, y, φ]``.

    z = 0 and the quaternion is the yaw rotation by φ; rows with a non-finite pose
    (a diverged filter) are left out so that tools such as ``evo`` can read the file.
    """
    ok = np.all(np.isfinite(poses), axis=1) & np.isfinite(times)
    t, p = times[ok], poses[ok]
    half = 0.5 * p[:, 2]
    cols = np.column_stack([t, p[:, 0], p[:, 1], np.zeros(len(t)), np.zeros(len(t)),
                            np.zeros(len(t)), np.sin(half), np.cos(half)])
    return "".join(" ".join(f"{v:.9g}" if j else f"{v:.6f}" for j, v in enumerate(r)) + "\n"
                   for r in cols)


def write_tum_files(result: CampaignResult, out_dir: Path) -> list[str]:
    """``truth.tum`` and ``<name>.tum`` for every estimator tracked on run 0."""
    first = result.outcomes[0]
    if first.truth is None or first.times is None:
        return []
    written = []
    for name, poses in [("truth", first.truth),
                        *((n, tr.poses) for n, tr in first.tracks.items())]:
        (out_dir / f"{name}.tum").write_text(tum_text(first.times, poses), encoding="utf-8")
        written.append(f"{name}.tum")
    return written


# --------------------------------------------------------------------------- writing

def render(result: CampaignResult, out_dir: Path, *, plots: bool = True) -> list[str]:
    """Write every output file into the existing folder ``out_dir`` (not atomic)."""
    kr = kind_report(result.summary.get("kind", "planar-slam"))
    (out_dir / SUMMARY).write_text(summary_json(result.summary), encoding="utf-8")
    figures: dict[str, bytes] = {}
    if plots:
        for name, (plot, _) in kr.figures().items():
            plot(result, out_dir / name)
            figures[name] = (out_dir / name).read_bytes()
    (out_dir / "report.md").write_text(report_markdown(result, list(figures)),
                                       encoding="utf-8")
    (out_dir / "report.html").write_text(report_html(result, figures), encoding="utf-8")
    extra = kr.extra_files(result, out_dir)
    return [SUMMARY, "report.md", "report.html", *figures, *extra]


def _default_dir_mode() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o777 & ~mask


def _swap_into_place(new: Path, out_dir: Path) -> None:
    """Move the finished folder ``new`` to ``out_dir``, replacing (then deleting) the
    old one; if the final rename fails the old folder is put back."""
    if out_dir.exists():
        new.chmod(stat.S_IMODE(out_dir.stat().st_mode))
        old = out_dir.with_name(f".{out_dir.name}.old-{uuid.uuid4().hex[:12]}")
        os.rename(out_dir, old)
        try:
            os.rename(new, out_dir)
        except BaseException:
            os.rename(old, out_dir)
            raise
        shutil.rmtree(old, ignore_errors=True)
    else:
        new.chmod(_default_dir_mode())
        os.rename(new, out_dir)


def write_outputs(result: CampaignResult, out_dir: Path, *, plots: bool = True) -> list[Path]:
    """Write the campaign's report folder atomically and return the files written.

    Everything is rendered into a temporary folder next to ``out_dir`` which then
    replaces ``out_dir`` in one rename; on any error the temporary folder is removed and
    an existing ``out_dir`` is left as it was.
    """
    out_dir = Path(out_dir).absolute()
    if out_dir.exists() and not out_dir.is_dir():
        raise NotADirectoryError(f"{out_dir} exists and is not a directory")
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=f".{out_dir.name}.tmp-"))
    try:
        names = render(result, tmp, plots=plots)
        _swap_into_place(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out_dir / n for n in names]
