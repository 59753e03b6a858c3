"""Figures of a ``spinning`` campaign: [Spin SR-CH∞KF] Fig. 5-8 re-drawn from our runs,
the shared navigation figures (:mod:`slam.render.figures`), the noise-mismatch sweep and
the flight.

    errors.png       pitch and yaw error vs time, every estimator in one panel (Fig. 5-6):
                     run 0's error and the Monte Carlo RMSE, the blind area shaded, with
                     the largest difference between the filters' curves written in
    roll.png         the roll each estimator implies vs time with the blind area shaded
                     (Fig. 7-8): the whole flight, and a zoom outside the blind area
    rmse_sigma.png   Monte Carlo RMSE vs the RMS of each estimator's own σ (blind shaded)
    nees.png         2-dof NEES / 2 and NIS vs time in their 95 % bands
    differences.png  each filter minus SRCKF on the same runs (blind shaded; curves that
                     coincide are named with their largest difference)
    sweep.png        pitch and yaw RMSE vs the noise factor per filter (H∞ per γ)
    flight.png       altitude vs range, pitch and yaw vs time, the body axis's angle to
                     the field line with the blind area
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.spinning.run import blind_mask
from slam.kinds.spinning.simulate import epochs, sim_config
from slam.kinds.spinning.truth import axis_field_angle, trajectory
from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.document import Figure
from slam.render.figures import (
    FigureSpec,
    figure_table,
    rmse_sigma_figure,
)
from slam.render.plotting import (
    bottom_legend,
    envelope,
    estimator_colours,
    filter_names,
    inch_layout,
    legend_margin,
    plt,
    run0,
    save,
    titled,
)
from slam.render.series import Component, column, good_scores, paired_differences, rms, stacked
from slam.results import REFERENCE, CampaignResult

DEG = 180.0 / math.pi
BLIND = {"color": "0.85", "lw": 0, "zorder": 0}


PITCH_YAW = [Component(a, "°", column("err", i, DEG), column("sigma", i, DEG))
             for i, a in enumerate(("pitch", "yaw"))]
"""The filters' state errors in degrees."""


def _shade(ax: Any, t: np.ndarray, blind: np.ndarray) -> None:
    if blind.any():
        ax.fill_between(t, 0, 1, where=blind, transform=ax.get_xaxis_transform(), **BLIND)


def _blind(result: CampaignResult) -> tuple[np.ndarray, np.ndarray]:
    """Run 0's epochs and its blind-area mask."""
    first = run0(result)
    return first.times, blind_mask(result.world, first.truth[:, 0], first.truth[:, 1])


def shade_blind(ax: Any, _c: Any, result: CampaignResult) -> None:
    """A shared figure's ``decorate``: the blind area shaded."""
    _shade(ax, *_blind(result))


STYLES = {"srchinf": {"ls": "--", "lw": 1.5}, "uthinf": {"ls": ":", "lw": 1.8}}
"""The H∞ filters dashed and dotted, so that they show over their Kalman twins."""


def _style(name: str) -> dict[str, Any]:
    return STYLES.get(name, {"ls": "-", "lw": 1.0})


def _handles(names: list[str], colours: dict[str, str], extra: list | None = None) -> list:
    from matplotlib.lines import Line2D

    return [Line2D([], [], color=colours[n], label="gtsam smoother" if n == REFERENCE else n,
                   **_style(n)) for n in names] + (extra or [])


def largest_difference(curves: dict[str, np.ndarray]) -> tuple[float, str, str] | None:
    """The largest absolute difference over the epochs between any two of ``curves``
    (name -> (E,)) and the pair it is between; ``None`` with fewer than two."""
    names = list(curves)
    best: tuple[float, str, str] | None = None
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            d = np.abs(curves[a] - curves[b])
            d = d[np.isfinite(d)]
            if d.size and (best is None or float(d.max()) > best[0]):
                best = (float(d.max()), a, b)
    return best


def coinciding(curves: dict[str, np.ndarray], rtol: float = 0.01
               ) -> list[tuple[list[str], float]]:
    """Groups of ``curves`` (name -> (E,)) drawn on top of each other: linked when their
    difference is within ``rtol`` of the panel's largest magnitude (log=False) at every epoch
    or, for positive curves on a log axis, within ``rtol`` relative at 95 % of the epochs;
    each group with its largest absolute difference."""
    names = list(curves)
    scale = max((float(np.nanmax(np.abs(v))) for v in curves.values() if np.isfinite(v).any()),
                default=0.0)

    def close(a: np.ndarray, b: np.ndarray) -> bool:
        ok = np.isfinite(a) & np.isfinite(b)
        if not ok.any():
            return False
        d = np.abs(a[ok] - b[ok])
        if np.all(a[ok] > 0) and np.all(b[ok] > 0):
            return float(np.mean(d / np.maximum(a[ok], b[ok]) < rtol)) >= 0.95
        return bool(np.all(d <= rtol * scale))

    groups: list[list[str]] = []
    for n in names:
        home = next((g for g in groups if any(close(curves[n], curves[m]) for m in g)), None)
        if home is None:
            groups.append([n])
        else:
            home.append(n)
    out = []
    for g in groups:
        if len(g) > 1:
            top = largest_difference({n: curves[n] for n in g})
            out.append((g, top[0] if top else 0.0))
    return out


def _note(ax: Any, curves: dict[str, np.ndarray], unit: str = "°") -> None:
    """Write which curves coincide (with their largest difference) and the largest
    difference between any two."""
    lines = [f"{' = '.join(g)} coincide (within {d:.2g}{unit})" for g, d in coinciding(curves)]
    top = largest_difference(curves)
    if top is not None:
        lines.append(f"largest difference {top[0]:.2g}{unit} ({top[1]} vs {top[2]})")
    if lines:
        ax.text(0.01, 0.97, "\n".join(lines), transform=ax.transAxes, va="top", fontsize=7.5,
                bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})


def plot_errors(result: CampaignResult, path: Path) -> None:
    """Pitch and yaw errors (the paper's Fig. 5-6): run 0's error and the Monte Carlo RMSE of
    every estimator in one panel per axis, the blind area shaded, the H∞ filters dashed, and
    the largest difference between the filters' curves written in each panel."""
    t, blind = _blind(result)
    filters = [n for n in filter_names(result) if n in run0(result).scores]
    names = [*filters, *([REFERENCE] if REFERENCE in run0(result).scores else [])]
    colours = estimator_colours(names)
    fig, axes = plt.subplots(2, 2, figsize=(11.5, 7.2), sharex=True, squeeze=False)
    inch_layout(fig, 2, 2, left=0.8, top=0.6, bottom=legend_margin(len(names), 5), wgap=0.8)
    for j, c in enumerate(PITCH_YAW):
        run_err, rmse = {}, {}
        for name in names:
            s = run0(result).scores[name]
            if not s.diverged:
                run_err[name] = c.err(s)
                axes[0, j].plot(t, run_err[name], color=colours[name], **_style(name))
            err = stacked(result, name, c.err)
            if err is not None:
                rmse[name] = rms(err)
                axes[1, j].plot(t, rmse[name], color=colours[name], **_style(name))
        for row, curves in ((0, run_err), (1, rmse)):
            ax = axes[row, j]
            _shade(ax, t, blind)
            _note(ax, {n: v for n, v in curves.items() if n != REFERENCE})
            ax.grid(True, lw=0.3, alpha=0.5)
        axes[0, j].axhline(0.0, color="0.5", lw=0.5)
        axes[0, j].set_title(f"{c.label}: run 0 error (grey: blind area)", fontsize=10)
        axes[1, j].set_title(f"{c.label}: Monte Carlo RMSE", fontsize=10)
        axes[1, j].set_yscale("log")
        axes[0, j].set_ylabel("error (°)")
        axes[1, j].set_ylabel("RMSE (°)")
        axes[1, j].set_xlabel("time (s)")
    bottom_legend(fig, _handles(names, colours), ncols=5)
    fig.suptitle(titled(result, "pitch and yaw errors (paper's Fig. 5-6)"), fontsize=10)
    save(fig, path)


def plot_differences(result: CampaignResult, path: Path, base: str = "srckf") -> None:
    """RMS over runs of each filter minus ``base`` (or the first filter) on the same runs,
    pitch and yaw, the blind area shaded, the base's RMS σ dotted; difference curves that
    lie within 1 % of each other are named with their largest difference."""
    from matplotlib.lines import Line2D

    t, blind = _blind(result)
    filters = filter_names(result)
    base = base if base in filters else filters[0]
    others = [n for n in filters if n != base]
    colours = estimator_colours(filters)
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.2), squeeze=False)
    inch_layout(fig, 1, 2, left=0.8, top=0.6, bottom=legend_margin(len(others) + 1, 5),
                wgap=0.8)
    for j, c in enumerate(PITCH_YAW):
        ax, curves = axes[0, j], {}
        for name in others:
            d = paired_differences(result, name, base, c.err)
            if d is None:
                continue
            r = rms(d)
            if np.all(r[np.isfinite(r)] == 0.0):
                ax.text(0.01, 0.03, f"{name} = {base} exactly", transform=ax.transAxes,
                        fontsize=8)
                continue
            curves[name] = r
            ax.plot(t, np.where(r > 0, r, np.nan), color=colours[name], **_style(name))
        sd = stacked(result, base, c.sigma)
        if sd is not None:
            ax.plot(t, rms(sd), color="0.2", lw=1.0, ls=":")
        _shade(ax, t, blind)
        _note(ax, curves)
        if curves:
            ax.set_yscale("log")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.set(title=f"{c.label}: RMS over runs of (filter − {base})", xlabel="time (s)",
               ylabel="RMS difference (°)")
    handles = _handles(others, colours, [Line2D([], [], color="0.2", lw=1.0, ls=":",
                                                label=f"{base}: RMS σ")])
    for h in handles[:len(others)]:
        h.set_label(f"{h.get_label()} − {base}")
    bottom_legend(fig, handles, ncols=5)
    fig.suptitle(titled(result, f"each filter minus {base} on the same runs "
                                "(grey: blind area)"), fontsize=10)
    save(fig, path)


def plot_roll(result: CampaignResult, path: Path) -> None:
    """The implied roll's error (deg) per estimator with the blind area shaded (Fig. 7-8)."""
    first = run0(result)
    t = first.times
    blind = blind_mask(result.world, first.truth[:, 0], first.truth[:, 1])
    names = [n for n in [*filter_names(result), REFERENCE] if n in first.scores]
    colours = estimator_colours(names)
    height = 1.2 + 1.7 * len(names)
    fig, axes = plt.subplots(len(names), 2, figsize=(11.0, height), sharex=True, squeeze=False)
    # the suptitle sits 2 % of the height below the top edge, the panel titles below it
    inch_layout(fig, len(names), 2, left=0.75, top=0.42 + 0.02 * height, bottom=0.5, wgap=0.8,
                hgap=0.15)
    zoom = 0.0
    for row, name in enumerate(names):
        err = first.scores[name].roll_err * DEG
        env = envelope(good_scores(result, name), lambda s: s.roll_err * DEG)
        for ax in axes[row]:
            _shade(ax, t, blind)
            if env is not None:
                ax.fill_between(t, env[0], env[1], color=colours[name], alpha=0.15, lw=0)
            ax.plot(t, err, color=colours[name], lw=0.8)
            ax.axhline(0.0, color="0.5", lw=0.5)
            ax.grid(True, lw=0.3, alpha=0.5)
            ax.set_ylabel(f"{name} (°)", fontsize=9)
        if env is not None and (~blind).any():
            zoom = max(zoom, float(np.nanmax(np.abs(np.stack(env)[:, ~blind]))))
    for row in range(len(names)):
        axes[row, 0].set_ylim(-185.0, 185.0)
        if zoom > 0.0:
            axes[row, 1].set_ylim(-1.1 * zoom, 1.1 * zoom)
    axes[0, 0].set_title("roll error, whole flight (grey: blind area)", fontsize=10)
    axes[0, 1].set_title("zoom on the errors outside the blind area", fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(titled(result, "roll from eq. 7-8 with each estimator's pitch and yaw "
                                "(paper's Fig. 7-8); run 0 and the Monte Carlo envelope"),
                 fontsize=10)
    save(fig, path)


def plot_sweep(result: CampaignResult, path: Path) -> None:
    """Pitch and yaw RMSE vs the noise factor, one line per sweep row, one row of panels per
    mismatch (gyro and magnetometer, gyro only, magnetometer only) and noise shape."""
    sweep = result.summary.get("sweep") or {}
    groups = [(sc, d) for sc in sweep.get("scales") or [] for d in sweep.get("distributions")
              or []]
    rows = sweep.get("rows") or []
    n = max(len(groups), 1)
    fig, axes = plt.subplots(n, 2, figsize=(11.0, 1.5 + 3.0 * n), squeeze=False)
    inch_layout(fig, n, 2, left=0.8, top=0.42 + 0.02 * (1.5 + 3.0 * n),
                bottom=legend_margin(max(len(rows), 1), 6), hgap=0.9)
    cmap = plt.get_cmap("tab10")
    for i, (scale, dist) in enumerate(groups):
        for j, axis in enumerate(("pitch", "yaw")):
            ax, drawn = axes[i, j], False
            for k, row in enumerate(rows):
                cells = sorted((c for c in sweep["cells"] if c["row"] == row
                                and c["distribution"] == dist and c["scale"] == scale
                                and c["logs"]), key=lambda c: c["factor"])
                f = [c["factor"] for c in cells]
                v = [np.nan if c[f"rmse_{axis}_deg"] is None else c[f"rmse_{axis}_deg"]
                     for c in cells]
                drawn = drawn or bool(np.any(np.asarray(v, dtype=float) > 0))
                style = "--" if "γ" in row else "-"
                ax.plot(f, v, style, marker="o", ms=3, lw=1.0, color=cmap(k % 10), label=row)
            ax.set_xscale("log")
            if drawn:
                ax.set_yscale("log")
            else:
                ax.text(0.5, 0.5, "no sweep log in this cell (fewer campaign runs than logs)",
                        transform=ax.transAxes, ha="center", fontsize=9)
            ax.set_xticks(sweep.get("factors") or [1.0],
                          [f"{f:g}×" for f in sweep.get("factors") or [1.0]])
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
            ax.set_xlabel("true noise / assumed noise")
            ax.set_ylabel(f"{axis} RMSE (°)")
            ax.set_title(f"{axis}: {SCALE_TITLES.get(scale, scale)} mismatched, {dist}",
                         fontsize=10)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(max(len(labels), 1), 6),
               fontsize=8, frameon=False)
    fig.suptitle(titled(result, "noise-mismatch sweeps: RMSE vs mismatch factor"), fontsize=10)
    save(fig, path)


SCALE_TITLES = {"both": "gyro and magnetometer", "gyro": "gyro only",
                "magnetometer": "magnetometer only"}


def plot_flight(result: CampaignResult, path: Path) -> None:
    """The truth: the trajectory, pitch and yaw, and the axis's angle to the field line."""
    world = result.world
    t = epochs(sim_config(world))
    flight = trajectory(world.flight)
    s = flight.sample(t)
    first = run0(result)
    alpha, beta = first.truth[:, 0], first.truth[:, 1]
    blind = blind_mask(world, alpha, beta)
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 3.6))
    inch_layout(fig, 1, 3, left=0.7, top=0.6, bottom=0.5, wgap=0.75)
    axes[0].plot(np.hypot(s[:, 0], s[:, 2]) / 1e3, s[:, 1] / 1e3, color="k")
    axes[0].set(xlabel="range (km)", ylabel="altitude (km)", title="trajectory")
    axes[1].plot(t, alpha * DEG, label="pitch α")
    axes[1].plot(t, beta * DEG, label="yaw β")
    axes[1].set(xlabel="time (s)", ylabel="deg", title="attitude (axis follows velocity)")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, axis_field_angle(world.field, alpha, beta) * DEG, color="k")
    _shade(axes[2], t, blind)
    axes[2].axhline(world.scoring.blind_area_rad * DEG, color="tab:red", ls="--", lw=0.8)
    axes[2].set(xlabel="time (s)", ylabel="deg",
                title="body axis to field line (grey: blind area)")
    for ax in axes:
        ax.grid(True, lw=0.3, alpha=0.5)
    fig.suptitle(titled(result, "flight and geomagnetic geometry"), fontsize=10)
    save(fig, path)


def figure_specs() -> list[FigureSpec]:
    """The report's figures, in report order."""
    return [
        FigureSpec("errors.png", "Pitch and yaw error vs time (the paper's Fig. 5-6), every "
                   "estimator in one panel: run 0's error (top) and the Monte Carlo RMSE per "
                   "epoch (bottom), the geomagnetic blind area shaded, SR-CH∞KF dashed and "
                   "UT-H∞ dotted over their Kalman twins. Each panel names the filters whose "
                   "curves coincide, with their largest difference, and the largest "
                   "difference between any two filters (differences.png draws them).",
                   plot_errors),
        FigureSpec("roll.png", "Roll error (eq. 7-8 with each estimator's pitch and yaw) vs "
                   "time, the geomagnetic blind area shaded (the paper's Fig. 7-8): run 0 and "
                   "the Monte Carlo envelope; right: the errors outside the blind area.",
                   plot_roll),
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch, pitch and yaw (deg), the blind area "
                   "shaded. A consistent filter's two curves coincide. The sigma-point "
                   "filters' curves lie on top of each other: errors.png names them with "
                   "their largest difference and differences.png draws it.",
                   rmse_sigma_figure([PITCH_YAW], "error vs predicted σ", log=True,
                                     decorate=shade_blind)),
        FigureSpec("nees.png", "2-dof pitch/yaw NEES / 2 and the magnetometer updates' NIS "
                   "per epoch (run averages) against their 95 % bands, with the fraction of "
                   "epochs inside; right: the per-run time averages.",
                   consistency_figure([NeesSpec("NEES / 2", 2, lambda s: s.nees)])),
        FigureSpec("differences.png", "Each filter minus SRCKF on the same runs: RMS over "
                   "runs per epoch of the pitch and yaw estimates (deg), with SRCKF's RMS σ "
                   "(dotted) for scale and the blind area shaded; SR-CH∞KF dashed, UT-H∞ "
                   "dotted. Curves drawn on top of each other are named in the panel with "
                   "their largest difference; a filter equal to SRCKF to the last bit is named "
                   "at the bottom.", plot_differences),
        FigureSpec("sweep.png", "Pitch and yaw RMSE vs the true/assumed noise factor, per "
                   "filter, one row per mismatch (both sensors, gyro only, magnetometer only) "
                   "and noise shape; the H∞ filters dashed, one line per γ.", plot_sweep),
        FigureSpec("flight.png", "The flight: trajectory, pitch and yaw, and the body axis's "
                   "angle to the field line with the blind area.", plot_flight),
    ]


def figures() -> dict[str, tuple[Figure, str]]:
    """File name -> (function drawing it, caption)."""
    return figure_table(figure_specs())
