"""The consistency figure: NEES and NIS vs time with their bands and the fraction of
epochs inside, next to histograms of the per-run values (:func:`consistency_figure`).

The verdict words (:func:`~slam.render.tables.verdict`) call a filter consistent only when
its ANEES is inside its band and at least :data:`~slam.render.tables.MIN_INSIDE` of the
epochs are; the figure shows both numbers for every estimator.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.ticker import MaxNLocator

from slam.render.figures import (
    PANEL_WIDTH,
    Colours,
    Figure,
    Names,
    default_colours,
    draw_band,
    filters_and_reference,
)
from slam.render.plotting import filter_names, plt, readable_log_axis, run0, save, titled
from slam.render.series import (
    EpochConsistency,
    nees_per_epoch,
    nis_per_epoch,
    per_run_anees,
    per_run_nis,
)
from slam.results import CampaignResult


@dataclass(frozen=True)
class NeesSpec:
    """One NEES of the consistency figure: its label (``"pose NEES / 3"``), its degrees of
    freedom and ``nees(scores) -> (E,)``."""

    label: str
    dof: int
    nees: Callable[[Any], np.ndarray]


def consistency_figure(specs: Sequence[NeesSpec], *, nis: bool = True,
                       estimators: Names = filters_and_reference,
                       colours: Colours = default_colours,
                       title: str = "consistency (run averages against their 95 % bands)"
                       ) -> Figure:
    """One row per NEES in ``specs`` and one for the filters' NIS (with ``nis``): the run
    average per epoch against its 95 % band, labelled with the fraction of epochs inside,
    and a histogram of the per-run values."""

    def draw(result: CampaignResult, path) -> None:
        names, col = estimators(result), colours(result)
        t = run0(result).times
        nis_rows = ({n: nis_per_epoch(result, n) for n in filter_names(result)} if nis
                    else {})
        nis_rows = {n: c for n, c in nis_rows.items() if c is not None}
        n_rows = len(specs) + bool(nis_rows)
        fig = plt.figure(figsize=(PANEL_WIDTH, 1.0 + 3.3 * n_rows), layout="constrained")
        grid = fig.add_gridspec(n_rows, 2, width_ratios=(3.0, 1.0))
        for i, spec in enumerate(specs):
            series = {n: nees_per_epoch(result, n, spec.nees, spec.dof) for n in names}
            per_run = {n: per_run_anees(result, n, spec.nees, spec.dof) for n in names}
            _row(fig, grid, i, t, series, per_run, col, spec.label, "ANEES")
        if nis_rows:
            per_run = {n: per_run_nis(result, n) for n in nis_rows}
            _row(fig, grid, len(specs), t, nis_rows, per_run, col, "NIS / dof",
                 "mean NIS/dof")
        fig.suptitle(titled(result, title), fontsize=11)
        save(fig, path)

    return draw


def _row(fig, grid, i: int, t: np.ndarray, series: dict[str, EpochConsistency | None],
         per_run: dict[str, np.ndarray], col: dict[str, str], label: str, mean_name: str
         ) -> None:
    ax, hx = fig.add_subplot(grid[i, 0]), fig.add_subplot(grid[i, 1])
    band = None
    for name, c in series.items():
        if c is None or not np.isfinite(c.value).any():
            continue
        ok = np.isfinite(c.value)
        avg = float(np.mean(c.value[ok]))
        inside = c.inside
        text = "" if inside is None else f", {100 * inside:.0f} % of epochs in band"
        ax.plot(t[ok], c.value[ok], color=col[name], lw=0.8, alpha=0.9,
                label=f"{name}: {mean_name} {avg:.2f}{text}")
        band = band or (c.lo, c.hi)
    if band is not None:
        draw_band(ax, t, *band)
    if ax.lines:
        ax.axhline(1.0, color="0.5", lw=0.6)
        ax.set_yscale("log")
        readable_log_axis(ax)
        ax.legend(fontsize=8, frameon=False, loc="upper left", bbox_to_anchor=(0.0, -0.2),
                  ncols=2)
    ax.set_ylabel(f"{label} (run average)", fontsize=9)
    ax.set_xlabel("time (s)", labelpad=1)
    ax.set_title(f"{label} per epoch", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)
    _histogram(hx, per_run, col, f"per-run {label}")


def _histogram(ax, per_run: dict[str, np.ndarray], col: dict[str, str], xlabel: str) -> None:
    values = [v for v in per_run.values() if len(v)]
    if not values:
        ax.axis("off")
        return
    edges = np.histogram_bin_edges(np.concatenate(values), bins=min(20, max(
        5, int(np.sqrt(max(len(v) for v in values))) + 2)))
    for name, v in per_run.items():
        if len(v):
            ax.hist(v, bins=edges, histtype="step", color=col[name], lw=1.3)
    ax.axvline(1.0, color="black", ls="--", lw=1.0)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(xlabel, fontsize=9)
    ax.set_ylabel("runs", fontsize=9)
    ax.set_title("per run (1 = consistent)", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)
