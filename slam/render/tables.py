"""Tables and JSON of a campaign summary: strict JSON, number cells, Markdown, plain
text and HTML tables.  Shared by every kind's report."""

from __future__ import annotations

import html
import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

MISSING = "—"
PAPER_AXES = ("x", "y", "z")


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


def diverged_cell(entry: dict[str, Any]) -> str:
    """``"2/50"``: runs diverged out of the runs made (``"2"`` if that is unknown)."""
    scored, diverged = entry.get("runs_scored"), entry.get("diverged_runs")
    runs = "" if scored is None or diverged is None else f"/{scored + diverged}"
    return MISSING if diverged is None else f"{diverged}{runs}"


def estimator_entries(summary: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """``(name, entry)`` of every estimator in table order: the filters, then the
    baselines (odometry, IMU only), then the reference smoother."""
    return [(name, entry) for group in ("filters", "baselines", "reference")
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


ESTIMATOR = Column("estimator", lambda name, entry: name)
POS_RMSE = Column("pos RMSE (m)", value("pos_rmse_m", ".3f"))
LANDMARK_RMSE = Column("landmark RMSE (m)", value("landmark_rmse_m", ".3f"))
NIS = Column("NIS/dof", value("nis_mean", ".2f"))
DIVERGED = Column("diverged runs", lambda name, entry: diverged_cell(entry))


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
    range per axis, ``orientation``, landmark RMSE, ``anees``, NIS/dof, ``time`` per step
    and the diverged runs."""
    return Table((ESTIMATOR, POS_RMSE, *map(error_range, axes), orientation, LANDMARK_RMSE,
                  *anees, NIS, time, DIVERGED))


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


def html_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An HTML table, cells escaped."""
    e = html.escape
    head = "".join(f"<th>{e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>\n" for r in rows)
    return f"<table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}</tbody>\n</table>"


def html_text(text: str) -> str:
    """Escape text, turning Markdown `code` spans into <code>."""
    parts = html.escape(text).split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


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
            row += [interval(paper.get(a)), interval(ours.get(a))]
        rows.append(row)
    return header, rows


def paper_range(summary: dict[str, Any], name: str, axis: str) -> list[float] | None:
    """The paper's quoted error range of filter ``name`` on ``axis`` (m), if any."""
    f = ((summary.get("paper") or {}).get("filters") or {}).get(name) or {}
    r = (f.get("pos_err_range_m") or {}).get(axis)
    return list(r) if isinstance(r, list | tuple) and len(r) == 2 else None
