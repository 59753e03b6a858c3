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
from matplotlib.ticker import LogLocator, MaxNLocator

from slam.render import plotting
from slam.render.figures import (
    PANEL_WIDTH,
    Colours,
    Figure,
    Names,
    default_colours,
    draw_band,
    filters_and_reference,
)
from slam.render.plotting import plt
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
        t = plotting.run0(result).times
        nis_rows = ({n: nis_per_epoch(result, n) for n in plotting.filter_names(result)} if nis
                    else {})
        nis_rows = {n: c for n, c in nis_rows.items() if c is not None}
        n_rows = len(specs) + bool(nis_rows)
        fig = plt.figure(figsize=(PANEL_WIDTH, 1.0 + 3.3 * n_rows))
        grid = fig.add_gridspec(n_rows, 2, width_ratios=(3.0, 1.0))
        plotting.inch_layout(fig, n_rows, 2, grid=grid, top=0.8, bottom=1.05, hgap=1.35, wgap=1.1,
                             right=0.3)
        for i, spec in enumerate(specs):
            series = {n: nees_per_epoch(result, n, spec.nees, spec.dof) for n in names}
            per_run = {n: per_run_anees(result, n, spec.nees, spec.dof) for n in names}
            _row(fig, grid, i, t, series, per_run, col, spec.label, "ANEES")
        if nis_rows:
            per_run = {n: per_run_nis(result, n) for n in nis_rows}
            _row(fig, grid, len(specs), t, nis_rows, per_run, col, "NIS / dof",
                 "mean NIS/dof")
        fig.suptitle(plotting.titled(result, title), fontsize=11)
        plotting.save(fig, path)

    return draw


def _row(fig, grid, i: int, t: np.ndarray, series: dict[str, EpochConsistency | None],
         per_run: dict[str, np.ndarray], col: dict[str, str], label: str, mean_name: str
         ) -> None:
    ax, hx = fig.add_subplot(grid[i, 0]), fig.add_subplot(grid[i, 1])
    band, shown = None, []
    for name, c in series.items():
        if c is None or not np.isfinite(c.value).any():
            continue
        ok = np.isfinite(c.value) & (c.value > 0)
        shown.append(c.value[ok])
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
        _robust_limits(ax, np.concatenate(shown), band)
        plotting.readable_log_axis(ax)
        ax.legend(fontsize=8, frameon=False, loc="upper left", ncols=2,
                  bbox_to_anchor=(0.0, 0.0, 1.0, 0.0), bbox_transform=_below(ax))
    ax.set_ylabel(f"{label} (run average)", fontsize=9)
    ax.set_xlabel("time (s)", labelpad=1)
    ax.set_title(f"{label} per epoch", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)
    _histogram(hx, per_run, col, f"per-run {label}")


def _below(ax):
    """A transform whose origin lies 0.42 inch below the axes' lower left corner: room for
    the x tick labels and the x label above a legend placed there."""
    from matplotlib.transforms import ScaledTranslation

    return ax.transAxes + ScaledTranslation(0.0, -0.42, ax.figure.dpi_scale_trans)


def _robust_limits(ax, values: np.ndarray, band) -> None:
    """Log y limits holding the band and 99 % of the values (0.5 % off either end): a
    start-up transient of a few epochs (e.g. the smoother's 1e-28 at a known start) must
    not flatten the rest."""
    lo, hi = np.percentile(values, [0.5, 99.5]) if values.size else (1.0, 1.0)
    if band is not None:
        edges = np.concatenate([band[0][np.isfinite(band[0])], band[1][np.isfinite(band[1])]])
        if edges.size:
            lo, hi = min(lo, float(edges.min())), max(hi, float(edges.max()))
    ax.set_ylim(0.8 * min(lo, 1.0), 1.25 * max(hi, 1.0))


def _histogram(ax, per_run: dict[str, np.ndarray], col: dict[str, str], xlabel: str) -> None:
    values = [v for v in per_run.values() if len(v)]
    if not values:
        ax.axis("off")
        return
    every = np.concatenate(values)
    bins = min(20, max(5, int(np.sqrt(max(len(v) for v in values))) + 2))
    wide = every.min() > 0 and every.max() > 10 * every.min()  # a heavy tail: log bins
    edges = (np.geomspace(every.min(), every.max(), bins + 1) if wide
             else np.histogram_bin_edges(every, bins=bins))
    for name, v in per_run.items():
        if len(v):
            ax.hist(v, bins=edges, histtype="step", color=col[name], lw=1.3)
    ax.axvline(1.0, color="black", ls="--", lw=1.0)
    if wide:  # a narrow panel: 1-2-5 ticks
        ax.set_xscale("log")
        plotting.readable_log_axis(ax, "x")
        ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(xlabel, fontsize=9)
    ax.set_ylabel("runs", fontsize=9)
    ax.set_title("per run (1 = consistent)", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)
