"""Figures of a ``ship`` campaign (from a :class:`~slam.results.CampaignResult` of
:func:`slam.kinds.ship.run.run_once` / ``summarize``):

    attitude_errors.png  the paper's Fig. 1-3 re-drawn: roll / pitch / yaw error (arcmin)
                         vs time, one row per filter: run 0 and its ±2σ, the Monte Carlo
                         envelope, the smoother's run 0 and the paper's bounds (dashed);
                         the y range of these three is set after the first 30 s, and a
                         fourth column draws the yaw error of the first 30 s on its own
                         scale (the transient from the initial yaw error, where the
                         paper's convergence claim is)
    convergence.png      median |error| over the runs (log scale) vs time per axis, every
                         estimator (solid: pseudo-observation, dashed: vector measurement;
                         coinciding ones drawn with decreasing widths) and the smoother,
                         the 10′ bound
    nees.png             run-averaged NEES / 6 vs time with its 95 % band, every estimator
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.ship.scoring import ARCMIN, AXES
from slam.render.figures import FigureSpec, figure_table
from slam.render.plotting import (
    ErrorGrid,
    ErrorPanel,
    envelope_and_run0,
    error_grid,
    estimator_colours,
    estimator_lines,
    good_scores,
    inch_layout,
    legend_margin,
    log_time_panels,
    nees_band_axes,
    plt,
    run0,
    run_average,
    save,
)
from slam.render.series import run_statistic
from slam.results import REFERENCE, Array, CampaignResult

SETTLE_S = 30.0


def _claim_bounds(summary: dict[str, Any], name: str, col: int) -> list[float] | None:
    claim = ((summary.get("paper") or {}).get("claims") or {}).get(name) or {}
    key = "yaw_within_arcmin" if col == 2 else "roll_pitch_within_arcmin"
    b = claim.get(key)
    return None if not isinstance(b, int | float) else [-float(b), float(b)]


def _names(result: CampaignResult) -> list[str]:
    s = result.summary
    first = result.outcomes[0]
    names = [*(s.get("filters") or {}), *(s.get("variants") or {}), REFERENCE]
    return [n for n in names if n in first.scores]


def plot_attitude_errors(result: CampaignResult, path: Path) -> None:
    """``attitude_errors.png`` (module docstring)."""
    first = run0(result)
    ref = first.scores.get(REFERENCE)
    settle = int(np.searchsorted(first.times, min(SETTLE_S, first.times[-1])))
    end = min(SETTLE_S, float(first.times[-1]))
    grid = ErrorGrid((*AXES, f"yaw (first {end:g} s)"), 16.0, 1.3, "{name}: {axis} (′)",
                     ("error", "sigma", "envelope", "paper", "reference"),
                     f"attitude error (arcmin; roll, pitch, yaw scaled after {end:g} s, "
                     f"the yaw transient of the first {end:g} s on the right)",
                     windows=(None, None, None, end))

    def panel(name: str, col: int) -> ErrorPanel:
        axis = min(col, 2)  # the fourth column is the yaw transient
        env, shown = envelope_and_run0(result, name, lambda s: s.err[:, axis] / ARCMIN,
                                       lambda s: s.sigma[:, axis] / ARCMIN)
        return ErrorPanel(env, shown, "" if shown else "diverged on run 0",
                          None if ref is None else ref.err[:, axis] / ARCMIN,
                          _claim_bounds(result.summary, name, axis),
                          settle=settle if col < 3 else 0)

    error_grid(result, path, grid, panel, estimator_colours(_names(result)))


def _treatments(summary: dict[str, Any]) -> dict[str, str]:
    return {n: e.get("treatment", "") for group in ("filters", "variants")
            for n, e in (summary.get(group) or {}).items()}


def _lines(result: CampaignResult, axes: Any, series: Callable[[str], Array | None]) -> None:
    """One line per estimator in each of ``axes``: solid with the pseudo-observation,
    dashed with the vector measurement (``manifold``), thin purple for the smoother;
    coinciding estimators stay visible because the first drawn is the widest."""
    names = _names(result)
    treatments = _treatments(result.summary)
    estimator_lines(axes, run0(result).times, names, estimator_colours(names), series,
                    style=lambda n: "--" if treatments.get(n) == "manifold" else "-")


def plot_convergence(result: CampaignResult, path: Path) -> None:
    """``convergence.png`` (module docstring)."""
    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.6), sharey=True)
    inch_layout(fig, 1, 3, left=0.75, top=0.55, bottom=legend_margin(len(_names(result)), 5),
                wgap=0.3)
    _lines(result, axes, lambda n: run_statistic(
        result, n, lambda e: np.nanmedian(np.abs(e), axis=0) / ARCMIN))
    bound = result.summary.get("converge_bound_arcmin")
    log_time_panels(fig, axes, result, [f"{axis}: median |error| over runs" for axis in AXES],
                    (bound,) * 3, "arcmin", "convergence (solid: Z = G q, dashed: B = C(q)ᵀR; "
                    "dotted: the 10′ bound)", path, 5)


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png`` (module docstring)."""
    fig, ax = plt.subplots(figsize=(10.0, 4.8))
    inch_layout(fig, 1, 1, left=0.75, top=0.35, bottom=0.55)

    def average(name: str) -> Array | None:
        scores = good_scores(result, name)
        return run_average([s.nees6 for s in scores], 6.0) if scores else None

    _lines(result, [ax], average)
    nees_band_axes(ax, result, 6, "attitude + drift NEES (6 dof) vs its 95 % band")
    save(fig, path)


def figure_specs() -> list[FigureSpec]:
    """The report's figures, in report order."""
    return [
        FigureSpec("attitude_errors.png",
                   "The paper's Fig. 1-3 re-drawn: roll, pitch and yaw error (′) vs time per "
                   "filter - run 0 with its ±2σ, the Monte Carlo envelope, the smoother's run "
                   "0 and the paper's bounds (dashed). The y range of roll, pitch and yaw is "
                   "set after 30 s; the right-hand column is the yaw error of the first 30 s "
                   "on its own scale, the transient from the initial yaw error where the "
                   "paper's convergence claim is.",
                   plot_attitude_errors),
        FigureSpec("convergence.png",
                   "Median |error| over the runs vs time (log scale), every estimator (solid: "
                   "pseudo-observation Z = G q, dashed: vector measurement B = C(q)ᵀR; "
                   "estimators that coincide are drawn with decreasing widths) and the "
                   "smoother; dotted: the 10′ bound.",
                   plot_convergence),
        FigureSpec("nees.png",
                   "Run-averaged NEES / 6 (attitude and drift) vs time with its 95 % χ² band "
                   "(line styles as in convergence.png).",
                   plot_nees),
    ]


def figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption), for
    :class:`~slam.render.document.KindReport` (named lazily by the report, so a run
    without figures never imports matplotlib)."""
    return figure_table(figure_specs())
