"""Figures of an ``attitude`` (star-sensor) campaign, built from
:class:`~slam.kinds.attitude.run.AttitudeScores` (all at the star epochs).

    attitude_errors.png  roll / pitch / yaw error (Z-X-Y Euler, arcsec) vs time per filter:
                         run 0 with its ±2σ, the Monte Carlo envelope, the smoother's run 0
    convergence.png      attitude error norm of every run, the Monte Carlo RMSE and the RMS
                         σ on a log axis (arcsec / arcmin / deg), with the prior's error at
                         t = 0: the convergence from the initial error (30′/60′ in §5.2)
    rmse_sigma.png       Monte Carlo RMSE vs RMS own σ: roll / pitch / yaw, bias x / y / z
    bias.png             run 0's gyro-bias estimates vs the truth (deg/h) with ±2σ
    nees.png             6-dof NEES / 6 and NIS / 3 vs time in their bands; per-run
                         histograms
    differences.png      each filter minus the best filter on attitude MSE, same runs

Where the filters' curves coincide (less than 1 % apart: on the §5.1 world they agree to
round-off) the figure's title says so with the largest difference (:func:`overdrawn`).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

from slam.kinds.attitude.run import ARCSEC, AXES, DEG_H
from slam.render import plotting
from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.figures import (
    PANEL_WIDTH,
    Figure,
    FigureSpec,
    Tracked,
    base_filter,
    default_colours,
    differences_figure,
    error_grid_figure,
    estimate_figure,
    figure_table,
    filters_and_reference,
    rmse_sigma_figure,
)
from slam.render.series import Component, coinciding, column, nees_per_epoch, rms, stacked
from slam.results import REFERENCE, Array, CampaignResult

EULER = "Z-X-Y Euler angles, the paper's convention"
ROLL_PITCH_YAW = [Component(a, "″", column("err_euler", i, 1 / ARCSEC),
                            column("sigma_euler", i, 1 / ARCSEC)) for i, a in enumerate(AXES)]
BIAS = [Component(a, "deg/h", column("err_bias", i, 1 / DEG_H),
                  column("sigma_bias", i, 1 / DEG_H), "bias")
        for i, a in enumerate(("x", "y", "z"))]
COINCIDE = (" If the filters' curves coincide (less than 1 % of the curve apart, drawn over "
            "each other), the title says so with the largest difference, computed on this "
            "campaign; differences.png draws the filters' differences.")
_ANGLE_TICKS = np.array([0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 60, 120, 300, 600, 1800,
                         3600, 7200, 18000, 36000])


def angle_axis(ax) -> None:
    """A log y axis in arcseconds labelled in ″, ′ and ° (60″ = 1′, 60′ = 1°)."""
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ticks = _ANGLE_TICKS[(_ANGLE_TICKS >= lo) & (_ANGLE_TICKS <= hi)]
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(FuncFormatter(
        lambda v, _: f"{v:g}″" if v < 60 else f"{v / 60:g}′" if v < 3600 else f"{v / 3600:g}°"))
    ax.yaxis.set_minor_formatter(NullFormatter())


# --------------------------------------------------------------------------- coinciding

def overdrawn(columns: dict[str, dict[str, Array | None]], units: dict[str, str]) -> str:
    """One line naming the filters whose curves coincide (:func:`slam.render.series.coinciding`:
    less than 1 % of the curve apart, so drawn over each other) in the figure's ``columns``
    (column -> filter -> curve), with the largest difference per unit; ``""`` if none do.
    E.g. ``"srukf, srcdkf, ekf drawn over srckf (largest difference 3.1e-07 ″, 2e-10 deg/h,
    < 1 %)"``."""
    on: dict[str, dict[str, int]] = {}
    worst: dict[str, float] = {}
    for col, curves in columns.items():
        for a, b, d in coinciding(curves):
            on.setdefault(a, {})[b] = on.get(a, {}).get(b, 0) + 1
            worst[units[col]] = max(worst.get(units[col], 0.0), d)
    if not on:
        return ""
    n = len(columns)
    groups = "; ".join(", ".join(b if k == n else f"{b} ({k} of {n} panels)"
                                 for b, k in others.items()) + f" drawn over {a}"
                       for a, others in on.items())
    return (f"{groups} (largest difference "
            + ", ".join(f"{d:.2g} {u}".rstrip() for u, d in worst.items()) + ", < 1 %)")


def _noted(title: str, note: str) -> str:
    return f"{title} - {note}" if note else title


def _filter_curves(result: CampaignResult, components: list[Component], statistic
                   ) -> dict[str, dict[str, Array | None]]:
    """Column -> filter -> ``statistic`` of the filter's (R, E) stack of that component."""
    names = plotting.filter_names(result)
    out: dict[str, dict[str, Array | None]] = {}
    for c in components:
        out[c.axis_label] = {}
        for n in names:
            err = stacked(result, n, c.err)
            out[c.axis_label][n] = None if err is None else statistic(err)
    return out


def _units(components: list[Component]) -> dict[str, str]:
    return {c.axis_label: c.unit for c in components}


def _decorate(ax, c: Component, result: CampaignResult) -> None:
    if c.unit == "″":
        angle_axis(ax)


def plot_attitude_errors(result: CampaignResult, path) -> None:
    """Run 0's roll / pitch / yaw errors (arcsec) with ±2σ, the Monte Carlo envelope and
    the smoother's run 0, one row per filter; the y range leaves out the first 10 s; the
    title names the rows whose run-0 errors coincide (:func:`overdrawn`)."""
    note = overdrawn(_filter_curves(result, ROLL_PITCH_YAW, lambda e: e[0]),
                     _units(ROLL_PITCH_YAW))
    error_grid_figure(ROLL_PITCH_YAW,
                      _noted("attitude error (Z-X-Y Euler), run 0 with its ±2σ",
                             note.replace("drawn over", "alike to")),
                      groups=((0, 1, 2),), settle_s=10.0)(result, path)


def plot_rmse_sigma(result: CampaignResult, path) -> None:
    """Monte Carlo RMSE vs RMS σ per component (:func:`slam.render.figures.rmse_sigma_figure`),
    the title naming the filters whose RMSE curves coincide."""
    comps = ROLL_PITCH_YAW + BIAS
    note = overdrawn(_filter_curves(result, comps, rms), _units(comps))
    rmse_sigma_figure([ROLL_PITCH_YAW, BIAS], _noted("error vs predicted σ", note), log=True,
                      decorate=_decorate)(result, path)


def plot_bias(result: CampaignResult, path) -> None:
    """Run 0's gyro-bias estimates (:func:`slam.render.figures.estimate_figure`), the title
    naming the filters whose estimates coincide."""
    first = plotting.run0(result)
    tracks = {n: first.tracks[n].bias / DEG_H for n in plotting.filter_names(result)
              if n in first.tracks}
    axes = ("x", "y", "z")
    note = overdrawn({f"bias {a}": {n: b[:, i] for n, b in tracks.items()}
                      for i, a in enumerate(axes)}, {f"bias {a}": "deg/h" for a in axes})
    estimate_figure([[_bias(i, a) for i, a in enumerate(axes)]],
                    _noted("gyro-bias estimates, run 0", note))(result, path)


def plot_nees(result: CampaignResult, path) -> None:
    """NEES / 6 and NIS / 3 against their bands
    (:func:`slam.render.consistency.consistency_figure`), the title naming the filters whose
    run-averaged NEES curves coincide."""
    spec = NeesSpec("NEES / 6", 6, lambda s: s.nees)
    curves = {n: None if (c := nees_per_epoch(result, n, spec.nees, spec.dof)) is None
              else c.value for n in plotting.filter_names(result)}
    note = overdrawn({spec.label: curves}, {spec.label: ""})
    consistency_figure([spec],
                       title=_noted("NEES and NIS (run averages) in their 95 % bands",
                                    note))(result, path)


def best_filter(result: CampaignResult) -> tuple[str, ...]:
    """The attitude ranking's best filter (then SRCKF): the base of differences.png."""
    best = ((result.summary.get("ranking") or {}).get("attitude") or {}).get("best")
    return (best, "srckf") if best else ("srckf",)


def plot_differences(result: CampaignResult, path) -> None:
    """Each filter minus the best filter on attitude (:func:`best_filter`) on the same runs."""
    differences_figure([ROLL_PITCH_YAW, BIAS], "each filter minus {base} (the best on attitude "
                       "MSE) on the same data", preferred=best_filter(result))(result, path)


def _norm_series(result: CampaignResult, name: str):
    err = stacked(result, name, lambda s: np.linalg.norm(s.err_body, axis=1) / ARCSEC)
    sd = stacked(result, name, lambda s: np.linalg.norm(s.sigma_body, axis=1) / ARCSEC)
    return err, sd


def plot_convergence(result: CampaignResult, path) -> None:
    """The attitude error norm (body-frame rotation angle, arcsec) of every run of the base
    filter (grey), the Monte Carlo RMSE (solid) and RMS σ (dashed) of every estimator,
    and the prior's error and σ at t = 0 (before the first star update), on a log axis:
    the whole run (left) and its first seconds (right)."""
    first, world = plotting.run0(result), result.world
    t, col = first.times, default_colours(result)
    names = filters_and_reference(result)
    base = base_filter(result)
    fs = world.filters
    prior = math.sqrt(float(np.sum(np.square(fs.initial_error_rad)))) / ARCSEC
    prior_sd = math.sqrt(3.0 * fs.initial_attitude_var_rad2) / ARCSEC
    zoom = t <= t[0] + max(min(20.0, 0.1 * (t[-1] - t[0])), 2.0)
    fig, axes = plotting.plt.subplots(1, 2, figsize=(PANEL_WIDTH, 4.6),
                                      width_ratios=(2.0, 1.0), sharey=True)
    plotting.inch_layout(fig, 1, 2, left=0.8, top=0.55, wgap=0.45,
                         bottom=plotting.legend_margin(len(names) + 5, 4))
    for ax, w in zip(axes, (np.ones_like(zoom), zoom)):
        for s in plotting.good_scores(result, base):
            ax.plot(t[w], np.linalg.norm(s.err_body, axis=1)[w] / ARCSEC, color="0.78", lw=0.5)
        for name in names:
            err, sd = _norm_series(result, name)
            ls = "--" if name == REFERENCE else "-"
            if err is not None:
                ax.plot(t[w], rms(err)[w], color=col[name], lw=1.3, ls=ls,
                        marker="." if w is zoom else None, ms=3)
            if sd is not None and np.isfinite(sd).any():
                ax.plot(t[w], rms(sd)[w], color=col[name], lw=0.9, ls=":")
        ax.plot([t[0]], [prior], "o", color="black", ms=7, zorder=5)
        ax.plot([t[0]], [prior_sd], "s", mfc="none", color="black", ms=7, zorder=5)
        ax.axhline(60.0, color="0.3", lw=0.8, ls="-.")
        ax.set_xlabel("time (s)")
        ax.grid(True, lw=0.3, alpha=0.5)
    for ax in axes:
        ax.set_ylabel("attitude error norm (arcsec; ′ = 60″)")
    axes[0].set_title("whole run", fontsize=10)
    axes[1].set_title("first seconds (one point per star update)", fontsize=10)
    angle_axis(axes[0])
    handles = [Line2D([], [], color=col[n], lw=1.3, label=f"{n}: Monte Carlo RMSE")
               for n in names]
    handles += [Line2D([], [], color="0.3", lw=0.9, ls=":", label="RMS of own σ"),
                Line2D([], [], color="0.78", lw=0.8, label=f"{base}: each run"),
                Line2D([], [], ls="none", marker="o", color="black",
                       label=f"prior error {prior / 60:.1f}′ (before the first update)"),
                Line2D([], [], ls="none", marker="s", mfc="none", color="black",
                       label=f"prior σ {prior_sd / 60:.1f}′"),
                Line2D([], [], color="0.3", lw=0.8, ls="-.", label="1′")]
    fig.legend(handles=handles, loc="outside lower center", ncols=4, fontsize=8,
               frameon=False)
    curves = {n: None if (e := _norm_series(result, n)[0]) is None else rms(e)
              for n in plotting.filter_names(result)}
    fig.suptitle(plotting.titled(result, _noted("convergence from the initial attitude error",
                                                overdrawn({"norm": curves}, {"norm": "″"}))),
                 fontsize=11)
    plotting.save(fig, path)


def _bias(i: int, axis: str) -> Tracked:
    return Tracked(f"gyro bias {axis}", "deg/h", lambda tr: tr.bias[:, i] / DEG_H,
                   lambda first: first.truth[:, 4 + i] / DEG_H,
                   lambda s: s.sigma_bias[:, i] / DEG_H)


def figure_specs() -> list[FigureSpec]:
    """The attitude report's figures, in report order.  Where the filters' curves coincide
    the figure's title says so with the largest difference (:func:`overdrawn`)."""
    return [
        FigureSpec("attitude_errors.png", f"Roll, pitch and yaw error ({EULER}, arcsec) vs "
                   "time, one row per filter: run 0 with its ±2σ band, the Monte Carlo "
                   "envelope (min/max over all runs) and the smoother's run 0. The y range "
                   "leaves out the first 10 s; convergence.png shows them." + COINCIDE,
                   plot_attitude_errors),
        FigureSpec("convergence.png", "Attitude error norm (body-frame rotation angle) on a "
                   "log axis: every run of the base filter (grey), the Monte Carlo RMSE "
                   "(solid; the smoother dashed) and RMS σ (dotted) of every estimator, and "
                   "the prior's error (dot) and σ (square) at t = 0, before the first star "
                   "update; right: the first seconds, one point per update." + COINCIDE,
                   plot_convergence),
        FigureSpec("rmse_sigma.png", f"Monte Carlo RMSE (solid) vs the RMS of each "
                   f"estimator's own σ (dashed) per star epoch, log axes: roll, pitch, yaw "
                   f"({EULER}, arcsec) and the gyro bias per body axis (deg/h). A consistent "
                   "filter's two curves coincide." + COINCIDE, plot_rmse_sigma),
        FigureSpec("bias.png", "Run 0: gyro-bias estimates against the true bias (black; "
                   "deg/h) per body axis, with each estimator's ±2σ (thin); the smoother "
                   "dashed. The y range leaves out the first 5 % of the run." + COINCIDE,
                   plot_bias),
        FigureSpec("nees.png", "6-dof NEES / 6 (attitude and bias error) and the star "
                   "updates' NIS / 3 per epoch (run averages) against their 95 % bands, with "
                   "the fraction of epochs inside; right: the per-run time averages."
                   + COINCIDE, plot_nees),
        FigureSpec("differences.png", f"Each filter minus the best filter on attitude MSE "
                   f"(the ranking's; its name is in the title) on the same runs: RMS over "
                   f"runs per epoch of roll, pitch, yaw ({EULER}, arcsec) and gyro bias "
                   "(deg/h), with the best filter's RMS σ (dotted). Filters that coincide "
                   "elsewhere are told apart here.", plot_differences),
    ]


def figures() -> dict[str, tuple[Figure, str]]:
    """The report's figures, file name -> (drawing function, caption); the report names
    this module lazily, so a run without figures never imports matplotlib."""
    return figure_table(figure_specs())
