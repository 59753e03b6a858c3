"""The figure-spec library: a kind's report is a list of :class:`FigureSpec` values, most of
them built here from a few :class:`~slam.render.series.Component` descriptions, so a new
scenario kind gets the standard navigation figures by describing its error components.

Builders (each returns a :data:`~slam.render.document.Figure`, ``draw(result, path)``):

:func:`error_grid_figure`
    run 0's error with its ±2σ, the Monte Carlo envelope, the smoother and the paper's
    range, one row per filter and one column per component;
:func:`rmse_sigma_figure`
    Monte Carlo RMSE vs time of every estimator next to the RMS of its own predicted σ,
    one panel per component (a consistent filter's two curves coincide);
:func:`differences_figure`
    each filter minus a base filter (SRCKF by default) on the same runs: what tells
    near-identical filters apart;
:func:`estimate_figure`
    run 0's estimates of a slowly varying quantity (e.g. sensor biases) against the truth,
    with each estimator's ±2σ;
:func:`map_figure`
    landmark RMSE, landmark NEES, landmarks in the state and the map covariance's trace
    vs time;
:func:`~slam.render.consistency.consistency_figure`
    NEES and NIS vs time in their χ² bands with the fraction of epochs inside, and
    histograms of the per-run values.

All of them read the per-epoch arrays the campaign's workers returned (nothing is re-run),
use only the runs an estimator did not diverge on, and draw ±2σ wherever a band is drawn.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.lines import Line2D

from slam.render.plotting import (
    BASELINE_COLOUR,
    ErrorGrid,
    ErrorPanel,
    bottom_legend,
    envelope_and_run0,
    error_grid,
    estimator_colours,
    filter_names,
    inch_layout,
    legend_margin,
    plt,
    readable_log_axis,
    run0,
    save,
    titled,
)
from slam.render.series import (
    Component,
    coincidence_note,
    map_per_epoch,
    paired_differences,
    rms,
    stacked,
)
from slam.render.tables import paper_range
from slam.results import REFERENCE, Array, CampaignResult

Figure = Callable[[CampaignResult, Any], None]
Names = Callable[[CampaignResult], list[str]]
Colours = Callable[[CampaignResult], dict[str, str]]
PANEL_WIDTH = 11.5
"""Width of a full-width figure (inches): about the report page's width at 110 dpi."""


@dataclass(frozen=True)
class FigureSpec:
    """One figure of a report: its file name, its caption and the function drawing it."""

    name: str
    caption: str
    draw: Figure


def figure_table(specs: Sequence[FigureSpec]) -> dict[str, tuple[Figure, str]]:
    """File name -> (draw, caption), the form :class:`~slam.render.document.KindReport`
    takes."""
    return {s.name: (s.draw, s.caption) for s in specs}


def filters_and_reference(result: CampaignResult) -> list[str]:
    """The filters, then the smoother if run 0 scored it."""
    return [*filter_names(result),
            *([REFERENCE] if REFERENCE in result.outcomes[0].scores else [])]


def default_colours(result: CampaignResult) -> dict[str, str]:
    """Palette colours for the filters, the smoother's and grey for the baselines."""
    return estimator_colours(filter_names(result),
                             baselines=tuple(result.summary.get("baselines") or ()))


def base_filter(result: CampaignResult, preferred: Sequence[str] = ("srckf",)) -> str | None:
    """The filter the others are compared with: the first of ``preferred`` that ran, else
    the first filter."""
    names = filter_names(result)
    return next((n for n in preferred if n in names), names[0] if names else None)


def _grid(rows: Sequence[Sequence[Any]], height: float = 2.45, width: float = PANEL_WIDTH):
    ncol = max(len(r) for r in rows)
    fig, axes = plt.subplots(len(rows), ncol, figsize=(width, 1.3 + height * len(rows)),
                             sharex=True, squeeze=False)
    for i, row in enumerate(rows):
        for j in range(len(row), ncol):
            axes[i, j].axis("off")
    return fig, axes


COINCIDE = ("Estimators whose curves coincide (largest difference below 1 % of the curve) are "
            "named above the legend with their largest difference.")
"""The caption sentence of a figure that notes its coinciding curves."""
NOTE_CHARS = 16
"""Characters of an 8-point figure note per inch of figure width."""


def _finish(fig, axes, result: CampaignResult, title: str, handles: list, path,
            note: str = "") -> None:
    """Axis labels, grid, the bottom legend with ``note`` (e.g. which curves coincide)
    written just above it, the fixed layout, the title; save."""
    for ax in axes[-1]:
        if ax.axison:
            ax.set_xlabel("time (s)")
    for ax in axes.flat:
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.tick_params(labelsize=9)
    bottom_legend(fig, handles)
    width, height = fig.get_size_inches()
    lines = textwrap.wrap(note, int(NOTE_CHARS * width))
    legend = legend_margin(len(handles), 6, row=0.22)
    if lines:
        fig.text(0.5, (legend - 0.45) / height, "\n".join(lines), ha="center", va="bottom",
                 fontsize=8)
    inch_layout(fig, *axes.shape, bottom=legend + 0.15 * len(lines))
    fig.suptitle(titled(result, title), fontsize=11)
    save(fig, path)


def _estimator_handles(names: Sequence[str], colours: dict[str, str]) -> list[Line2D]:
    return [Line2D([], [], color=colours[n], lw=1.6, label=n) for n in names]


def _top(values: list[Array]) -> float:
    finite = [v[np.isfinite(v)] for v in values]
    finite = [v for v in finite if v.size]
    return float(max(np.max(v) for v in finite)) if finite else 0.0


# --------------------------------------------------------------------------- RMSE vs σ

def rmse_sigma_figure(rows: Sequence[Sequence[Component]], title: str, *, log: bool = False,
                      estimators: Names = filters_and_reference,
                      colours: Colours = default_colours,
                      decorate: Callable[[Any, Component, CampaignResult], None] | None = None,
                      note_coinciding: bool = False) -> Figure:
    """Monte Carlo RMSE (solid) and RMS of the estimator's own σ (dashed) vs time, one
    panel per component; ``decorate(ax, component, result)`` adds kind-specific marks;
    ``note_coinciding`` writes above the legend which estimators' curves coincide, with
    their largest difference (:func:`slam.render.series.coincidence_note`)."""

    def draw(result: CampaignResult, path) -> None:
        names, col = estimators(result), colours(result)
        t = run0(result).times
        fig, axes = _grid(rows)
        curves: dict[str, dict[str, Array | None]] = {}
        units: dict[str, str] = {}
        for i, row in enumerate(rows):
            for j, c in enumerate(row):
                ax, drawn = axes[i, j], []
                own = f"{c.axis_label} σ"
                units[c.axis_label] = units[own] = c.unit
                for name in names:
                    err = stacked(result, name, c.err)
                    if err is None:
                        continue
                    drawn.append(rms(err))
                    curves.setdefault(c.axis_label, {})[name] = drawn[-1]
                    ax.plot(t, drawn[-1], color=col[name], lw=1.1)
                    sd = None if c.sigma is None else stacked(result, name, c.sigma)
                    if sd is not None:
                        drawn.append(rms(sd))
                        curves.setdefault(own, {})[name] = drawn[-1]
                        ax.plot(t, drawn[-1], color=col[name], lw=1.1, ls="--")
                ax.set_title(c.axis_label, fontsize=10)
                ax.set_ylabel(f"RMSE, σ ({c.unit})", fontsize=9)
                if log:
                    ax.set_yscale("log")
                    readable_log_axis(ax)
                elif _top(drawn) > 0:
                    ax.set_ylim(0.0, 1.08 * _top(drawn))
                if decorate is not None:
                    decorate(ax, c, result)
        styles = [Line2D([], [], color="0.2", lw=1.1, label="Monte Carlo RMSE"),
                  Line2D([], [], color="0.2", lw=1.1, ls="--", label="RMS of own σ")]
        note = coincidence_note(curves, units, "curves") if note_coinciding else ""
        _finish(fig, axes, result, title, _estimator_handles(names, col) + styles, path, note)

    return draw


# --------------------------------------------------------------------------- error grid

Paper = Callable[[CampaignResult, str, Component], Any]
"""``paper(result, filter, component)`` -> the paper's quoted range for that panel, or None."""


def quoted_position_range(result: CampaignResult, name: str, c: Component) -> Any:
    """The paper's quoted position error range of filter ``name`` on axis ``c.label``
    (``summary["paper"]``, :func:`~slam.render.tables.paper_range`)."""
    return paper_range(result.summary, name, c.label) if c.group == "position" else None


def error_grid_figure(columns: Sequence[Component], title: str, *,
                      groups: Sequence[Sequence[int]] = (), paper: Paper | None = None,
                      settle_s: float = 0.0, colours: Colours = default_colours) -> Figure:
    """One row per filter, one column per component: run 0's error with its ±2σ, the Monte
    Carlo envelope (min / max over the runs the filter did not diverge on), the smoother's
    run-0 error and, with ``paper``, the paper's quoted range (dashed).  Columns in one of
    ``groups`` share a y range; the y range leaves out the first ``settle_s`` seconds."""

    def draw(result: CampaignResult, path) -> None:
        first = run0(result)
        ref = first.scores.get(REFERENCE)
        settle = int(np.searchsorted(first.times, first.times[0] + settle_s))

        def panel(name: str, col: int) -> ErrorPanel:
            c = columns[col]
            env, shown = envelope_and_run0(result, name, c.err, c.sigma)
            note = "diverged on every run" if env is None else "diverged on run 0"
            smoother = None if ref is None or ref.diverged else c.err(ref)
            return ErrorPanel(env, shown, note if col == 0 else "", smoother,
                              None if paper is None else paper(result, name, c), settle)

        grid = ErrorGrid([c.axis_label for c in columns], PANEL_WIDTH, 1.3,
                         "{name}: {axis} ({unit})",
                         ("error", "sigma", "envelope", "paper", "reference"), title,
                         groups=groups, units=[c.unit for c in columns])
        error_grid(result, path, grid, panel, colours(result))

    return draw


# --------------------------------------------------------------------------- differences

def differences_figure(rows: Sequence[Sequence[Component]], title: str, *,
                       preferred: Sequence[str] = ("srckf",),
                       colours: Colours = default_colours) -> Figure:
    """RMS over runs of (filter − base filter) per epoch, one panel per component, on a
    log axis, with the base filter's RMS σ (dotted) for scale."""

    def draw(result: CampaignResult, path) -> None:
        base, col = base_filter(result, preferred), colours(result)
        others = [n for n in filter_names(result) if n != base]
        t = run0(result).times
        fig, axes = _grid(rows)
        for i, row in enumerate(rows):
            for j, c in enumerate(row):
                ax = axes[i, j]
                floor = _difference_panel(ax, result, t, c, base, others, col)
                ax.set_title(c.axis_label, fontsize=10)
                ax.set_ylabel(f"RMS difference ({c.unit})", fontsize=9)
                if floor is not None:
                    ax.set_yscale("log")
                    ax.set_ylim(floor, ax.get_ylim()[1])  # not the start's round-off
                    readable_log_axis(ax)
        handles = [Line2D([], [], color=col[n], lw=1.1, label=f"{n} − {base}") for n in others]
        handles.append(Line2D([], [], color="0.2", lw=1.0, ls=":", label=f"{base}: RMS σ"))
        _finish(fig, axes, result, title.format(base=base), handles, path)

    return draw


def _difference_panel(ax, result: CampaignResult, t: Array, c: Component, base: str | None,
                      others: list[str], col: dict[str, str]) -> float | None:
    """Draw the differences; -> the y axis' floor (half the 2nd percentile of the drawn
    differences, so the round-off at a known start stays off the axis), None if none."""
    if base is None or not others:
        ax.text(0.5, 0.5, "one filter: nothing to compare", transform=ax.transAxes,
                ha="center", fontsize=9)
        return None
    floors = []
    for name in others:
        d = paired_differences(result, name, base, c.err)
        if d is None:
            continue
        r = rms(d)
        positive = r[np.isfinite(r) & (r > 0)]
        if positive.size:
            ax.plot(t, np.where(r > 0, r, np.nan), color=col[name], lw=1.0)
            floors.append(0.5 * float(np.percentile(positive, 2)))
        else:
            ax.text(0.02, 0.9, f"{name} = {base} exactly", transform=ax.transAxes, fontsize=8)
    sd = None if c.sigma is None else stacked(result, base, c.sigma)
    if floors and sd is not None:
        ax.plot(t, rms(sd), color="0.2", lw=1.0, ls=":")
    return min(floors) if floors else None


# --------------------------------------------------------------------------- estimate vs truth

@dataclass(frozen=True)
class Tracked:
    """A slowly varying quantity estimated by the filters, drawn for run 0 against the
    truth: label, unit, ``estimate(track) -> (E,)``, ``truth(run0 outcome) -> (E,)`` and
    ``sigma(scores) -> (E,)`` (all in the plotted unit)."""

    label: str
    unit: str
    estimate: Callable[[Any], Array]
    truth: Callable[[Any], Array]
    sigma: Callable[[Any], Array] | None = None


def estimate_figure(rows: Sequence[Sequence[Tracked]], title: str, *,
                    estimators: Names = filters_and_reference,
                    colours: Colours = default_colours, settle: float = 0.05) -> Figure:
    """Run 0: the truth (black), each estimator's estimate and its ±2σ (thin, same colour);
    the y range leaves out the first ``settle`` of the run (the prior's wide band)."""

    def draw(result: CampaignResult, path) -> None:
        first, col = run0(result), colours(result)
        names = [n for n in estimators(result) if n in first.tracks]
        t = first.times
        late = t >= t[0] + settle * (t[-1] - t[0])
        fig, axes = _grid(rows)
        for i, row in enumerate(rows):
            for j, q in enumerate(row):
                ax, shown = axes[i, j], [q.truth(first)]
                for name in names:
                    est = q.estimate(first.tracks[name])
                    ls = "--" if name == REFERENCE else "-"
                    ax.plot(t, est, color=col[name], lw=1.1, ls=ls)
                    shown.append(est)
                    sd = None if q.sigma is None else q.sigma(first.scores[name])
                    if sd is not None and np.isfinite(sd).any():
                        for sign in (-1.0, 1.0):
                            ax.plot(t, est + sign * 2 * sd, color=col[name], lw=0.6,
                                    alpha=0.6, ls=ls)
                            shown.append(est + sign * 2 * sd)
                ax.plot(t, shown[0], color="black", lw=1.5)
                _fit(ax, [v[late] for v in shown])
                ax.set_title(q.label, fontsize=10)
                ax.set_ylabel(f"{q.label} ({q.unit})", fontsize=9)
        handles = [Line2D([], [], color="black", lw=1.5, label="truth"),
                   *_estimator_handles(names, col),
                   Line2D([], [], color="0.3", lw=0.6, label="estimate ±2σ (own)")]
        _finish(fig, axes, result, title, handles, path)

    return draw


def _fit(ax, values: list[Array]) -> None:
    v = np.concatenate([np.asarray(x, float).ravel() for x in values])
    v = v[np.isfinite(v)]
    if v.size:
        lo, hi = float(v.min()), float(v.max())
        pad = 0.08 * max(hi - lo, 1e-12)
        ax.set_ylim(lo - pad, hi + pad)


# --------------------------------------------------------------------------- the map

MAP_PANELS = {"landmark RMSE": "m", "landmark NEES / dof": "", "landmarks in the state": "",
              "map covariance trace": "m²"}
"""The map figure's panels (as a coincidence note names them) and their units."""


def map_figure(title: str = "the map over time", *, estimators: Names = filter_names,
               colours: Colours = default_colours) -> Figure:
    """Landmark RMSE, landmark NEES / dof with its band, landmarks in the state and the
    trace of the map's covariance vs time (run averages of the filters' map series); the
    smoother's final landmark RMSE as a horizontal line; above the legend, which filters'
    curves coincide (:func:`slam.render.series.coincidence_note`)."""

    def draw(result: CampaignResult, path) -> None:
        names, col = estimators(result), colours(result)
        t = run0(result).times
        fig, axes = _grid([[0, 1], [2, 3]], height=2.6)
        (a_rmse, a_nees), (a_n, a_tr) = axes
        band = None
        curves: dict[str, dict[str, Array | None]] = {k: {} for k in MAP_PANELS}
        for name in names:
            m = map_per_epoch(result, name)
            if m is None:
                continue
            for key, y in zip(MAP_PANELS, (m.rmse, m.nees.value, m.count, m.trace)):
                curves[key][name] = y
            a_rmse.plot(t, m.rmse, color=col[name], lw=1.0)
            a_nees.plot(t, m.nees.value, color=col[name], lw=0.9,
                        label=_inside_label(name, m.nees.inside))
            a_n.plot(t, m.count, color=col[name], lw=1.0)
            a_tr.plot(t, np.where(m.trace > 0, m.trace, np.nan), color=col[name], lw=1.0)
            band = band or (m.nees.lo, m.nees.hi)
        ref = ((result.summary.get("reference") or {}).get(REFERENCE) or {}).get(
            "landmark_rmse_m")
        if ref:
            a_rmse.axhline(ref, color=col.get(REFERENCE, BASELINE_COLOUR), ls="--", lw=1.1,
                           label=f"{REFERENCE} (final map) {ref:.3f} m")
            a_rmse.legend(fontsize=8, frameon=False)
        if band is not None:
            draw_band(a_nees, t, *band)
        a_rmse.set_ylabel("landmark RMSE (m)", fontsize=9)
        a_nees.set_ylabel("landmark NEES / dof", fontsize=9)
        a_n.set_ylabel("landmarks in the state", fontsize=9)
        a_tr.set_ylabel("trace of map covariance (m²)", fontsize=9)
        for ax in (a_nees, a_tr):
            if ax.lines:
                ax.set_yscale("log")
                readable_log_axis(ax)
        if a_nees.lines:
            a_nees.legend(fontsize=8, frameon=False)
        for ax, what in ((a_rmse, "landmark position RMSE (landmarks in the state)"),
                         (a_nees, "landmark consistency (run average)"),
                         (a_n, "map size (run mean)"), (a_tr, "map uncertainty (run mean)")):
            ax.set_title(what, fontsize=10)
        _finish(fig, axes, result, title, _estimator_handles(names, col), path,
                coincidence_note(curves, MAP_PANELS, "curves"))

    return draw


def _inside_label(name: str, inside: float | None) -> str:
    return name if inside is None else f"{name}: {100 * inside:.0f} % of epochs in band"


def draw_band(ax, t: Array, lo: Array, hi: Array, label: str = "95 % band") -> None:
    """The per-epoch 95 % band: dashed edges (a constant band), or a grey area (a band that
    varies from epoch to epoch); a constant band's edges are written on the right."""
    ok = np.isfinite(lo) & np.isfinite(hi)
    if not ok.any():
        return
    lo_ok, hi_ok = lo[ok], hi[ok]
    if np.ptp(lo_ok) < 1e-9 and np.ptp(hi_ok) < 1e-9:
        for v in (lo_ok[0], hi_ok[0]):
            ax.axhline(v, color="black", ls="--", lw=1.0)
            ax.annotate(f"{v:.2f}", (1.0, v), xycoords=("axes fraction", "data"),
                        xytext=(2, 0), textcoords="offset points", va="center", fontsize=8,
                        annotation_clip=False)
        ax.plot([], [], color="black", ls="--", lw=1.0, label=label)
    else:
        ax.fill_between(t[ok], lo_ok, hi_ok, color="0.5", alpha=0.22, lw=0, label=label)
