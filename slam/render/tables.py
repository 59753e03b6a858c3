"""Tables and JSON of a campaign summary: strict JSON, number cells, Markdown, plain
text and HTML tables.  Shared by every kind's report."""

from __future__ import annotations

import html
import json
import math
import os
import textwrap
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from slam.results import REFERENCE

MISSING = "—"
PAPER_AXES = ("x", "y", "z")
TERMINAL_WIDTH = 100
"""The terminal table and its notes fit this many columns."""
MIN_INSIDE = 0.90
"""Fraction of epochs inside the per-epoch 95 % band needed to call a filter consistent."""


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


def num(v: Any, fmt: str, scale: float = 1.0) -> str:
    if (v is None or isinstance(v, bool) or not isinstance(v, int | float | np.number)
            or not math.isfinite(v)):
        return MISSING
    return format(float(v) * scale, fmt)


def interval(pair: Any, fmt: str = "+.2f") -> str:
    if not isinstance(pair, list | tuple) or len(pair) != 2:
        return MISSING
    lo, hi = (num(v, fmt) for v in pair)
    return MISSING if MISSING in (lo, hi) else f"[{lo}, {hi}]"


def anees_cell(entry: dict[str, Any], key: str = "anees", band: str = "anees_bounds_95"
               ) -> str:
    """``"1.02 [0.21, 2.41]"``: the ANEES at ``key`` and its 95 % band at ``band``."""
    value = num(entry.get(key), ".2f")
    if value == MISSING:
        return MISSING
    bounds = interval(entry.get(band), ".2f")
    return value if bounds == MISSING else f"{value} {bounds}"


def verdict(entry: dict[str, Any], key: str = "anees", band: str = "anees_bounds_95",
            inside: str = "anees_steps_inside_95", above: str = "anees_steps_above_95"
            ) -> str:
    """The consistency of a summary entry in a word (``""`` without a NEES).

    ``consistent`` only when the ANEES is inside its 95 % band AND at least
    :data:`MIN_INSIDE` of the epochs' run-averaged NEES are; otherwise ``optimistic``
    (overconfident: the ANEES above the band, or most epochs outside it above),
    ``pessimistic`` (too cautious: below) or ``mixed`` (outside on both sides, ANEES
    inside)."""
    value, bounds, frac = entry.get(key), entry.get(band), entry.get(inside)
    if num(value, "g") == MISSING or interval(bounds) == MISSING:
        return ""
    lo, hi = bounds
    if value > hi:
        return "optimistic"
    if value < lo:
        return "pessimistic"
    if num(frac, "g") == MISSING:
        return ""
    if frac >= MIN_INSIDE:
        return "consistent"
    up = entry.get(above)
    if num(up, "g") == MISSING:
        return "mixed"
    outside = 1.0 - frac
    return ("optimistic" if up >= 0.75 * outside else
            "pessimistic" if up <= 0.25 * outside else "mixed")


def consistency_rule() -> str:
    """The rule :func:`verdict` applies, in words (for the reports' notes)."""
    return (f"A filter is called consistent only when its ANEES lies inside the 95 % band "
            f"AND at least {100 * MIN_INSIDE:.0f} % of the epochs' run-averaged NEES lie "
            "inside it (a consistent filter scores about 95 %); otherwise the verdict says "
            "on which side it fails: optimistic (overconfident: NEES above the band, errors "
            "larger than the filter's own σ) or pessimistic (too cautious: below); mixed: "
            "outside on both sides.")


def percent(v: Any) -> str:
    """``"78 %"`` from a fraction."""
    return num(v, ".0f", 100.0) + " %" if num(v, "g") != MISSING else MISSING


def diverged_cell(entry: dict[str, Any]) -> str:
    """``"2/50"``: runs diverged out of the runs made (``"2"`` if that is unknown)."""
    scored, diverged = entry.get("runs_scored"), entry.get("diverged_runs")
    runs = "" if scored is None or diverged is None else f"/{scored + diverged}"
    return MISSING if diverged is None else f"{diverged}{runs}"


def estimator_entries(summary: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """``(name, entry)`` of every estimator in table order: the filters, the online rows
    (iSAM2, fixed-lag smoothers: planar), the baselines (odometry, IMU only), then the
    reference smoother."""
    return [(name, entry) for group in ("filters", "online", "baselines", "reference")
            for name, entry in (summary.get(group) or {}).items()]


Cell = Callable[[str, dict[str, Any]], str]
"""A table cell from an estimator's name and summary entry."""


@dataclass(frozen=True)
class Column:
    """One column of a results table: its header and how to fill a cell."""

    header: str
    cell: Cell


def value(key: str, fmt: str, scale: float = 1.0) -> Cell:
    """The cell of the number at ``key``, times ``scale``, formatted with ``fmt``."""
    return lambda name, entry: num(entry.get(key), fmt, scale)


def error_range(axis: str) -> Column:
    """The extreme position errors on ``axis`` (m)."""
    return Column(f"{axis} range (m)",
                  lambda name, entry: interval((entry.get("pos_err_range_m") or {}).get(axis)))


def anees_column(header: str, key: str = "anees", band: str = "anees_bounds_95") -> Column:
    """The ANEES at ``key`` with its 95 % band (:func:`anees_cell`)."""
    return Column(header, lambda name, entry: anees_cell(entry, key, band))


def consistency_keys(prefix: str = "anees") -> tuple[str, str, str, str]:
    """The summary keys of one NEES: value, band, fraction of epochs inside, above."""
    return (prefix, f"{prefix}_bounds_95", f"{prefix}_steps_inside_95",
            f"{prefix}_steps_above_95")


def consistency_columns(prefix: str = "anees", what: str = "", band: bool = True,
                        headers: Sequence[str] | None = None) -> tuple[Column, ...]:
    """ANEES (with its band unless ``band`` is False), the fraction of epochs inside the
    band and the :func:`verdict`, for the keys of :func:`consistency_keys`; ``headers``
    replaces the three default headers."""
    keys = consistency_keys(prefix)
    sep = " " if what else ""
    h = headers or (f"ANEES{sep}{what}" + (" [95 % band]" if band else ""),
                    f"{what}{sep}in band".strip(), f"{what}{sep}verdict".strip())
    first = (anees_column(h[0], keys[0], keys[1]) if band else
             Column(h[0], value(keys[0], ".2f")))
    return (first, Column(h[1], lambda n, e: percent(e.get(keys[2]))),
            Column(h[2], lambda n, e: verdict(e, *keys) or MISSING))


ESTIMATOR = Column("estimator", lambda name, entry: name)
POS_RMSE = Column("pos RMSE (m)", value("pos_rmse_m", ".3f"))
LANDMARK_RMSE = Column("landmark RMSE (m)", value("landmark_rmse_m", ".3f"))
NIS = Column("NIS/dof", value("nis_mean", ".2f"))
DIVERGED = Column("diverged runs", lambda name, entry: diverged_cell(entry))

EPOCH_TIME = "ms/epoch"
RUN_TIME = "s/run"
TERMINAL_HEADERS: dict[str, str] = {
    "estimator": "estimator", "ANEES": "ANEES", "epochs in band": "in band",
    "verdict": "verdict", "filter time per epoch": EPOCH_TIME,
    "estimator time per run": RUN_TIME, "diverged runs": "diverged",
}
"""One header per quantity in every kind's terminal table (quantity -> header; a test
holds each kind to it): a filter's wall time per epoch (one prediction over the sensor
period plus its update, a kind's "cycle") in ms, an estimator's per run in s, the
diverged runs as ``"d/n"``, the share of epochs in the ANEES band as ``"78 %"``."""

DIVERGED_SHORT = Column(TERMINAL_HEADERS["diverged runs"], DIVERGED.cell)
"""The diverged runs under the terminal tables' header."""


def epoch_time(key: str, fmt: str = ".3f") -> Column:
    """A filter's wall time per epoch (summary key ``key``, seconds) in ms, under the
    terminal header :data:`EPOCH_TIME`; none for the smoother, a batch solve whose cost
    is per run (:func:`smoother_cost`)."""
    cell = value(key, fmt, 1e3)
    return Column(EPOCH_TIME, lambda n, e: MISSING if n == REFERENCE else cell(n, e))


@dataclass(frozen=True)
class Table:
    """A results table: a row per estimator (in :func:`estimator_entries` order)."""

    columns: tuple[Column, ...]

    @property
    def header(self) -> tuple[str, ...]:
        return tuple(c.header for c in self.columns)

    def rows(self, summary: dict[str, Any]) -> list[list[str]]:
        return [[c.cell(name, entry) for c in self.columns]
                for name, entry in estimator_entries(summary)]

    def markdown(self, summary: dict[str, Any]) -> str:
        return markdown_table(self.header, self.rows(summary))

    def plain(self, summary: dict[str, Any]) -> str:
        """Aligned plain text (for the terminal)."""
        return plain_table(self.header, self.rows(summary))


def slam_table(axes: Iterable[str], orientation: Column, anees: Iterable[Column],
               time: Column) -> Table:
    """The results table of a SLAM kind: the estimator, its position RMSE and error
    range per axis, ``orientation``, landmark RMSE, ``anees`` (e.g.
    :func:`consistency_columns`), NIS/dof, ``time`` per step and the diverged runs."""
    return Table((ESTIMATOR, POS_RMSE, *map(error_range, axes), orientation, LANDMARK_RMSE,
                  *anees, NIS, time, DIVERGED))


def terminal_text(table: Table, summary: dict[str, Any], notes: Iterable[str] = ()) -> str:
    """A compact terminal table (headers may hold a line break) followed by the failure
    reasons of every estimator that diverged and the ``notes``, every line wrapped to
    :data:`TERMINAL_WIDTH` columns."""
    lines = [plain_table(table.header, table.rows(summary))]
    lines += [wrap(n) for n in [*failure_notes(summary), *notes] if n]
    return "\n".join(lines)


def wrap(text: str, width: int = TERMINAL_WIDTH) -> str:
    """``text`` wrapped to ``width`` columns, continuation lines indented by two."""
    return textwrap.fill(text, width, subsequent_indent="  ", break_on_hyphens=False)


def failure_notes(summary: dict[str, Any]) -> list[str]:
    """One line per estimator that diverged on some run: how often, and why."""
    out = []
    for name, entry in estimator_entries(summary):
        diverged = entry.get("diverged_runs")
        if isinstance(diverged, int) and not isinstance(diverged, bool) and diverged > 0:
            reasons = "; ".join(r for r in entry.get("failures") or [] if r) or "no reason given"
            out.append(f"{name} diverged on {diverged_cell(entry)} runs: {reasons}")
        elif entry.get("diverged") is True:
            out.append(f"{name} diverged: {entry.get('failure') or 'no reason given'}")
    return out


def landmark_anees_rule(dof: int) -> str:
    """How the landmark ANEES (:func:`slam.scoring.landmark_anees_entries`) is formed and
    what its band means, in words (for the reports' notes)."""
    return (f"Landmark ANEES: at each epoch the NEES of every mapped landmark ({dof} dof) "
            f"summed over the landmarks and runs, divided by {dof} × their number, averaged "
            "over the epochs; its 95 % band is that of the median number of landmark blocks "
            "per epoch, and 'in band' counts the epochs inside their own band (what "
            "landmarks.png draws). The band treats the landmarks' NEES as independent; they "
            "share the vehicle's error, so the true spread is wider and a verdict near the "
            "band's edge is weak evidence (the ANEES itself, a mean, is not affected).")


def smoother_cost(summary: dict[str, Any], how: str, reference: str = "gtsam") -> str:
    """The smoother's cost in its own unit, seconds per run (``time_s``, else
    ``time_per_run_s`` of its ``reference`` entry; with ``marginals_time_s`` if there is
    one), in one sentence; ``how`` names its method; ``""`` without a timed smoother."""
    r = (summary.get("reference") or {}).get(reference) or {}
    seconds = r.get("time_s", r.get("time_per_run_s"))
    if num(seconds, "g") == MISSING:
        return ""
    marg = r.get("marginals_time_s")
    extra = (f" and {num(marg, '.2f')} s for its marginals" if num(marg, "g") != MISSING
             else "")
    return (f"The {reference} smoother is a batch solve ({how}): {num(seconds, '.2f')} s per "
            f"run{extra}; the filters' cost is per epoch.")


def band_note(summary: dict[str, Any], key: str = "anees_bounds_95", what: str = "ANEES"
              ) -> str:
    """The 95 % band(s) of the summary's ANEES and the verdict rule, in one note."""
    bands = sorted({interval(e.get(key), ".2f") for _, e in estimator_entries(summary)}
                   - {MISSING})
    if not bands:
        return ""
    return (f"{what} 95 % band {' / '.join(bands)}; in band: epochs whose run average lies "
            f"inside it; verdict: consistent only if the {what} and at least "
            f"{100 * MIN_INSIDE:.0f} % of epochs are in the band.")


def cell_text(value: Any) -> str:
    """A table cell as text: a string as it is, anything else a report passes through from
    a free-form table (a number, a list, ``None``) as JSON (``None``: the missing mark)."""
    if isinstance(value, str):
        return value
    if value is None:
        return MISSING
    try:
        return json.dumps(value, ensure_ascii=False, allow_nan=True, default=str)
    except (TypeError, ValueError):  # a circular or exotic value
        return str(value)


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A GitHub-flavoured Markdown table, numbers right-aligned (line breaks in header
    cells become spaces, pipes in cells are escaped; a cell that is not text is shown as
    :func:`cell_text`)."""
    def cell(c: Any) -> str:
        return cell_text(c).replace("\n", " ").replace("|", "\\|")

    align = ["---"] + ["---:"] * (len(header) - 1)
    lines = ["| " + " | ".join(map(cell, header)) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(map(cell, r)) + " |" for r in rows]
    return "\n".join(lines)


def plain_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An aligned plain-text table: first column left-aligned, the others right-aligned.

    A header cell may hold line breaks (``"pos RMSE\\n(m)"``): the header then takes as
    many lines, bottom-aligned, and the column is only as wide as its longest line."""
    split = [h.split("\n") for h in header]
    depth = max(len(h) for h in split)
    head = [[""] * (depth - len(h)) + h for h in split]  # bottom-aligned
    head_rows = [[h[i] for h in head] for i in range(depth)]
    body = [[cell_text(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in head_rows + body) for i in range(len(header))]

    def line(r: list[str]) -> str:
        cells = [r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:], widths[1:])]
        return "  ".join(cells).rstrip()

    rule = "  ".join("-" * w for w in widths)
    return "\n".join([*map(line, head_rows), rule] + [line(r) for r in body])


def html_table(header: Sequence[str], rows: Iterable[Sequence[str]], cls: str | None = None
               ) -> str:
    """An HTML table, cells escaped (``cls``: its CSS class)."""
    e = html.escape
    head = "".join(f"<th>{e(h.replace(chr(10), ' '))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{e(cell_text(c))}</td>" for c in r) + "</tr>\n"
                   for r in rows)
    attr = f' class="{e(cls)}"' if cls else ""
    return f"<table{attr}>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}</tbody>\n</table>"


def html_text(text: str) -> str:
    """Escape text, turning Markdown `code` spans into <code>."""
    parts = html.escape(text).split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


def table_at(table: Any, *path: str) -> dict[str, Any]:
    """The table at ``path`` inside ``table`` (``{}`` if a step is missing or not a
    table): reading a free-form table such as ``summary["paper"]`` whatever it holds."""
    for key in path:
        table = table.get(key) if isinstance(table, dict) else None
    return table if isinstance(table, dict) else {}


def paper_rows(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the "paper vs ours" error-range table (empty if none quoted)."""
    quoted = {n: table_at(f, "pos_err_range_m")
              for n, f in table_at(summary, "paper", "filters").items()
              if table_at(f, "pos_err_range_m")}
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
            row += [interval(paper.get(a)), interval(ours.get(a))]
        rows.append(row)
    return header, rows


def paper_range(summary: dict[str, Any], name: str, axis: str) -> list[float] | None:
    """The paper's quoted error range of filter ``name`` on ``axis`` (m), if any."""
    r = table_at(summary, "paper", "filters", name, "pos_err_range_m").get(axis)
    ok = (isinstance(r, list | tuple) and len(r) == 2
          and all(isinstance(v, int | float) and not isinstance(v, bool) for v in r))
    return list(r) if ok else None
