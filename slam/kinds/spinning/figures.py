"""Figures of a ``spinning`` campaign: [Spin SR-CH∞KF] Fig. 5-8 re-drawn from our runs,
the shared navigation figures (:mod:`slam.render.figures`), the noise-mismatch sweep and
the flight.

    errors.png       pitch and yaw error vs time, one row per filter (Fig. 5-6): run 0 with
                     its ±2σ, the Monte Carlo envelope, the smoother's run 0
    roll.png         the roll each estimator implies vs time with the blind area shaded
                     (Fig. 7-8): the whole flight, and a zoom outside the blind area
    rmse_sigma.png   Monte Carlo RMSE vs the RMS of each estimator's own σ
    nees.png         2-dof NEES / 2 and NIS vs time in their 95 % bands
    differences.png  each filter minus SRCKF on the same runs
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
    differences_figure,
    error_grid_figure,
    figure_table,
    rmse_sigma_figure,
)
from slam.render.plotting import (
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
from slam.render.series import Component, column, good_scores
from slam.results import REFERENCE, CampaignResult

DEG = 180.0 / math.pi
BLIND = {"color": "0.85", "lw": 0, "zorder": 0}


PITCH_YAW = [Component(a, "°", column("err", i, DEG), column("sigma", i, DEG))
             for i, a in enumerate(("pitch", "yaw"))]
"""The filters' state errors in degrees."""


def _shade(ax: Any, t: np.ndarray, blind: np.ndarray) -> None:
    if blind.any():
        ax.fill_between(t, 0, 1, where=blind, transform=ax.get_xaxis_transform(), **BLIND)


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
    """Pitch and yaw RMSE vs the noise factor, one line per sweep row."""
    sweep = result.summary.get("sweep") or {}
    dists = sweep.get("distributions") or []
    rows = sweep.get("rows") or []
    n = max(len(dists), 1)
    fig, axes = plt.subplots(n, 2, figsize=(11.0, 1.5 + 3.3 * n), squeeze=False)
    inch_layout(fig, n, 2, left=0.8, top=0.42 + 0.02 * (1.5 + 3.3 * n),
                bottom=legend_margin(max(len(rows), 1), 6), hgap=0.9)
    cmap = plt.get_cmap("tab20")
    for i, dist in enumerate(dists):
        for j, axis in enumerate(("pitch", "yaw")):
            ax = axes[i, j]
            for k, row in enumerate(rows):
                cells = sorted((c for c in sweep["cells"] if c["row"] == row
                                and c["distribution"] == dist and c["logs"]),
                               key=lambda c: c["factor"])
                f = [c["factor"] for c in cells]
                v = [c[f"rmse_{axis}_deg"] for c in cells]
                v = [np.nan if x is None else x for x in v]
                style = "--" if "γ" in row else "-"
                ax.plot(f, v, style, marker="o", ms=3, lw=1.0, color=cmap(k % 20), label=row)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xticks(sweep.get("factors") or [1.0],
                          [f"{f:g}×" for f in sweep.get("factors") or [1.0]])
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
            ax.set_xlabel("true noise / assumed noise")
            ax.set_ylabel(f"{axis} RMSE (°)")
            ax.set_title(f"{axis}, {dist} noise", fontsize=10)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 6),
               fontsize=8, frameon=False)
    fig.suptitle(titled(result, "noise-mismatch sweep: RMSE vs mismatch factor"), fontsize=10)
    save(fig, path)


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
        FigureSpec("errors.png", "Pitch and yaw error vs time per filter (the paper's Fig. "
                   "5-6): run 0 with its ±2σ, the Monte Carlo envelope (min/max over the "
                   "runs) and the smoother's run 0.",
                   error_grid_figure(PITCH_YAW, "pitch and yaw errors (paper's Fig. 5-6)")),
        FigureSpec("roll.png", "Roll error (eq. 7-8 with each estimator's pitch and yaw) vs "
                   "time, the geomagnetic blind area shaded (the paper's Fig. 7-8): run 0 and "
                   "the Monte Carlo envelope; right: the errors outside the blind area.",
                   plot_roll),
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch, pitch and yaw (deg). A consistent "
                   "filter's two curves coincide.",
                   rmse_sigma_figure([PITCH_YAW], "error vs predicted σ", log=True)),
        FigureSpec("nees.png", "2-dof pitch/yaw NEES / 2 and the magnetometer updates' NIS "
                   "per epoch (run averages) against their 95 % bands, with the fraction of "
                   "epochs inside; right: the per-run time averages.",
                   consistency_figure([NeesSpec("NEES / 2", 2, lambda s: s.nees)])),
        FigureSpec("differences.png", "Each filter minus SRCKF on the same runs: RMS over "
                   "runs per epoch of the pitch and yaw estimates (deg), with SRCKF's RMS σ "
                   "(dotted).",
                   differences_figure([PITCH_YAW], "each filter minus {base} on the same data")),
        FigureSpec("sweep.png", "Pitch and yaw RMSE vs the true/assumed noise factor, per "
                   "filter; the H∞ filters dashed, one line per γ.", plot_sweep),
        FigureSpec("flight.png", "The flight: trajectory, pitch and yaw, and the body axis's "
                   "angle to the field line with the blind area.", plot_flight),
    ]


def figures() -> dict[str, tuple[Figure, str]]:
    """File name -> (function drawing it, caption)."""
    return figure_table(figure_specs())
