"""Figures of an ``alignment`` campaign (from a :class:`~slam.results.CampaignResult` of
:func:`slam.kinds.alignment.run.run_once` / ``summarize``):

    misalignment_errors.png  the paper's Fig. 1 re-drawn and extended: East / North /
                             azimuth misalignment error (arcmin) vs time, one row per
                             filter: run 0 with its ±2σ, the Monte Carlo envelope, the
                             smoother's run 0 (keys 1 s apart, joined), on every row the
                             paper's UT-H∞ values (dashed) and the level limit ±∇/g
                             (dotted); the y range of East and North is set after the
                             first 10 s
    rms.png                  Monte Carlo RMS of each axis vs time (log scale), every
                             estimator, with the level limit ∇/g (dotted)
    nees.png                 run-averaged misalignment NEES / 3 vs time with its 95 % band
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.alignment.scoring import ARCMIN, AXES
from slam.render import plotting
from slam.render.figures import FigureSpec, figure_table
from slam.render.plotting import plt
from slam.render.series import coincidence_note, run_statistic
from slam.results import REFERENCE, Array, CampaignResult

SETTLE_S = 10.0
PAPER_KEYS = {0: "east_final_arcmin", 1: "north_final_arcmin"}


def _names(result: CampaignResult) -> list[str]:
    first = result.outcomes[0]
    return [n for n in [*(result.summary.get("filters") or {}), REFERENCE] if n in first.scores]


def _joined(t: Array, y: Array) -> Array | None:
    """``y`` with its NaN gaps filled linearly between finite values (for drawing)."""
    ok = np.isfinite(y)
    return None if ok.sum() < 2 else np.interp(t, t[ok], y[ok])


PAPER_FILTER = "uthinf"
"""The filter whose final errors the paper gives (drawn on every row, to compare)."""


def _paper(summary: dict[str, Any], col: int) -> list[float] | None:
    """± the paper's final UT-H∞ error on East / North (``None`` for the azimuth)."""
    claim = ((summary.get("paper") or {}).get("claims") or {}).get(PAPER_FILTER) or {}
    v = claim.get(PAPER_KEYS.get(col, ""))
    return None if not isinstance(v, int | float) else [-float(v), float(v)]


def _limit(summary: dict[str, Any], col: int) -> list[float] | None:
    """± the level limit ∇/g (arcmin) on East / North (``None`` for the azimuth)."""
    tilt = (summary.get("limits") or {}).get("tilt_limit_arcmin")
    return [-float(tilt), float(tilt)] if col < 2 and isinstance(tilt, int | float) else None


def plot_errors(result: CampaignResult, path: Path) -> None:
    """``misalignment_errors.png`` (module docstring)."""
    first = plotting.run0(result)
    t = first.times
    ref = first.scores.get(REFERENCE)
    settle = int(np.searchsorted(t, min(SETTLE_S, t[-1] / 2)))
    grid = plotting.ErrorGrid(AXES, 13.0, 1.3, "{name}: {axis} (′)",
                              ("error", "sigma", "envelope", "paper", "limit", "reference"),
                              "misalignment error (arcmin; East/North range set after 10 s)",
                              groups=((0, 1),))

    def panel(name: str, col: int) -> plotting.ErrorPanel:
        env, shown = plotting.envelope_and_run0(result, name,
                                                lambda s: s.err[:, col] / ARCMIN,
                                                lambda s: s.sigma[:, col] / ARCMIN)
        joined = None if ref is None else _joined(t, ref.err[:, col] / ARCMIN)
        return plotting.ErrorPanel(env, shown, "" if shown else "diverged on run 0", joined,
                                   _paper(result.summary, col), settle if col < 2 else 0,
                                   _limit(result.summary, col))

    names = [n for n in _names(result) if n != REFERENCE]
    run0 = {n: first.scores[n].err / ARCMIN for n in names if n in first.scores}
    plotting.error_grid(result, path, grid, panel, plotting.estimator_colours(_names(result)),
                        names, coincidences(run0, t, "run 0's curves"))


def coincidences(curves: dict[str, Array], t: Array, what: str) -> str:
    """Which estimators' curves (M, 3) coincide per axis, after the first 10 s on East and
    North (:func:`slam.render.series.coincidence_note`)."""
    settle = t >= min(SETTLE_S, t[-1] / 2)
    columns = {axis: {n: np.where(settle if i < 2 else True, c[:, i], np.nan)
                      for n, c in curves.items()} for i, axis in enumerate(AXES)}
    return coincidence_note(columns, dict.fromkeys(AXES, "′"), what)


def plot_rms(result: CampaignResult, path: Path) -> None:
    """``rms.png`` (module docstring)."""
    t = plotting.run0(result).times
    names = _names(result)
    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.9))

    def rms(name: str) -> Array | None:
        return run_statistic(result, name, lambda e: np.sqrt(np.nanmean(e**2, axis=0)) / ARCMIN)

    note = coincidences({n: y for n in names if n != REFERENCE and (y := rms(n)) is not None},
                        t, "RMS curves")
    lines = textwrap.wrap(note, 190)
    if lines:
        fig.text(0.5, 0.27 / fig.get_size_inches()[1], "\n".join(lines), ha="center",
                 va="bottom", fontsize=8)

    def column(name: str, y: Array, col: int) -> Array | None:
        return y[:, col] if name != REFERENCE else _joined(t, y[:, col])

    plotting.inch_layout(fig, 1, 3, left=0.75, top=0.55, wgap=0.75,
                         bottom=plotting.legend_margin(len(names), 6) + 0.16 * len(lines))
    plotting.estimator_lines(axes, t, names, plotting.estimator_colours(names), rms, column)
    tilt = (result.summary.get("limits") or {}).get("tilt_limit_arcmin")
    plotting.log_time_panels(fig, axes, result, [f"{axis}: RMS over runs" for axis in AXES],
                             (tilt, tilt, None), "arcmin",
                             "misalignment RMS (dotted: the level limit ∇/g)", path, 6)


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png`` (module docstring)."""
    fig, ax = plt.subplots(figsize=(10.0, 4.8))
    plotting.inch_layout(fig, 1, 1, left=0.75, top=0.35, bottom=0.55)
    t = plotting.run0(result).times
    names = _names(result)
    colours = plotting.estimator_colours(names)
    for name in names:
        scores = plotting.good_scores(result, name)
        if not scores:
            continue
        y = plotting.run_average([s.nees for s in scores], 3.0)
        if name == REFERENCE:
            ok = np.isfinite(y)
            ax.plot(t[ok], y[ok], color=colours[name], lw=1.0, marker=".", ms=3, label=name)
        else:
            ax.plot(t, y, color=colours[name], lw=1.0, label=name)
    plotting.nees_band_axes(ax, result, 3, "misalignment NEES (3 dof) vs its 95 % band")
    plotting.save(fig, path)


def figure_specs() -> list[FigureSpec]:
    """The report's figures, in report order."""
    return [
        FigureSpec("misalignment_errors.png",
                   "The paper's Fig. 1 re-drawn (and the azimuth): East, North and azimuth "
                   "misalignment error (′) vs time per filter - run 0 with its ±2σ, the Monte "
                   "Carlo envelope, the smoother's run 0 (keys 1 s apart, joined); on every "
                   "row the paper's final UT-H∞ errors (± the world's [paper] claims, "
                   "dashed) and the level limit ±∇/g from the world's accelerometer bias "
                   "(dotted). East/North y range set after 10 s. Rows whose run-0 curves "
                   "coincide (largest difference below 1 % of the curve) are named under "
                   "the figure, with their largest difference.",
                   plot_errors),
        FigureSpec("rms.png",
                   "Monte Carlo RMS of the misalignment error vs time (log scale), every "
                   "estimator; dotted: the level limit ∇/g from the world's accelerometer "
                   "bias. Curves that coincide (largest difference below 1 % of the curve, "
                   "after 10 s on East and North) are named under the figure, with their "
                   "largest difference.",
                   plot_rms),
        FigureSpec("nees.png",
                   "Run-averaged 3-dof misalignment NEES / 3 vs time with its 95 % χ² band "
                   "(the smoother at its keys, where its marginals exist).",
                   plot_nees),
    ]


def figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption), for
    :class:`~slam.render.document.KindReport` (named lazily by the report, so a run
    without figures never imports matplotlib)."""
    return figure_table(figure_specs())
