"""The drone report's figures built from the shared figure-spec library
(:mod:`slam.render.figures`): the error components of a
:class:`~slam.kinds.drone.scoring.DroneScores` and the specs drawn from them.

    rmse_sigma.png   Monte Carlo RMSE vs RMS own σ: position, velocity, attitude, track
    bias.png         run 0's gyro / accelerometer bias estimates vs truth with ±2σ
    nees.png         position / pose / attitude NEES and NIS vs time in their bands
    landmarks.png    the map over time
    differences.png  each filter minus SRCKF on the same runs
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.drone.scene import IMU_ONLY, drone_colours, result_terrain
from slam.kinds.planar.figures import online_colours, with_online
from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.figures import (
    COINCIDE,
    FigureSpec,
    Tracked,
    differences_figure,
    error_grid_figure,
    estimate_figure,
    figure_table,
    map_figure,
    quoted_position_range,
    rmse_sigma_figure,
)
from slam.render.plotting import filter_names, good_scores, inch_layout, plt, run0, save, titled
from slam.render.series import Component, column
from slam.results import REFERENCE, CampaignResult

DEG = 180.0 / math.pi
DEG_H = math.pi / 180.0 / 3600.0  # deg/h -> rad/s
MG = 9.80665e-3  # milli-g -> m/s²
_XYZ = ("x", "y", "z")
_RPY = ("roll", "pitch", "yaw")


POSITION = [Component(a, "m", column("err_pos", i), column("sig_pos", i), "position")
            for i, a in enumerate(_XYZ)]
VELOCITY = [Component(a, "m/s", column("err_vel", i), column("sig_vel", i), "velocity")
            for i, a in enumerate(_XYZ)]
ATTITUDE = [Component(a, "deg", column("err_att", i, DEG), column("sig_att", i, DEG))
            for i, a in enumerate(_RPY)]
TRACK = [Component("along-track", "m", column("err_track", 0), column("sig_track", 0)),
         Component("cross-track", "m", column("err_track", 1), column("sig_track", 1)),
         Component("horizontal", "m", lambda s: np.hypot(s.err_pos[:, 0], s.err_pos[:, 1]),
                   lambda s: np.hypot(s.sig_pos[:, 0], s.sig_pos[:, 1]), "position")]


def _bias(kind: str, i: int, axis: str) -> Tracked:
    col, scale, unit = (i, DEG_H, "deg/h") if kind == "gyro" else (3 + i, MG, "mg")
    return Tracked(f"{kind} bias {axis}", unit,
                   lambda tr: tr.bias[:, col] / scale,
                   lambda first: first.truth[:, 10 + col] / scale,
                   lambda s: None if s.sig_bias is None else s.sig_bias[:, col] / scale)


BIASES = [[_bias("gyro", i, a) for i, a in enumerate(_XYZ)],
          [_bias("accelerometer", i, a) for i, a in enumerate(_XYZ)]]

NEES = [NeesSpec("position NEES / 3", 3, lambda s: s.nees_pos),
        NeesSpec("pose NEES / 6", 6, lambda s: s.nees_pose),
        NeesSpec("attitude NEES / 3", 3,
                 lambda s: s.nees_att if s.nees_att is not None else np.full(
                     len(s.nees_pos), np.nan))]


def shared_specs() -> list[FigureSpec]:
    """The drone's figures drawn by the shared builders."""
    return [
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch: position, velocity, attitude (deg, "
                   "Z-Y-X Euler), and the horizontal error along and across the true "
                   "direction of travel. A consistent filter's two curves coincide; the "
                   "smoother has no velocity σ; IMU only is left out (see drift.png). "
                   + COINCIDE, rmse_sigma_figure([POSITION, VELOCITY, ATTITUDE, TRACK],
                                                 "error vs predicted σ",
                                                 note_coinciding=True)),
        FigureSpec("bias.png", "Run 0: gyro (deg/h) and accelerometer (mg) bias estimates "
                   "against the truth (black, a random walk from the drawn turn-on bias), "
                   "each filter's ±2σ (thin); the smoother dashed. The y range leaves out "
                   "the first 5 % of the flight.",
                   estimate_figure(BIASES, "sensor bias estimates, run 0")),
        FigureSpec("nees.png", "Position NEES / 3, pose NEES / 6 ([position, body-frame "
                   "attitude]) and attitude NEES / 3 per epoch (run averages) against their "
                   "95 % bands with the fraction of epochs inside, and the filters' NIS / "
                   "dof (grey: its band, which varies with the landmarks seen); right: the "
                   "per-run time averages. The online row (isam2: the online optimum), when "
                   "run, is drawn beside the filters.",
                   consistency_figure(NEES, estimators=with_online, colours=online_colours)),
        FigureSpec("landmarks.png", "The filters' maps per epoch (run averages): RMSE and "
                   "NEES / 3 of the landmarks in the state (against the band), landmarks in "
                   "the state, trace of the map covariance; the smoother's final landmark "
                   "RMSE dashed. " + COINCIDE, map_figure("the map over time")),
        FigureSpec("differences.png", "Each filter minus the base filter (SRCKF) on the "
                   "same runs (truth cancels): RMS over runs per epoch of the position and "
                   "attitude (Z-Y-X Euler) differences, with the base filter's RMS σ "
                   "(dotted).", differences_figure([POSITION, ATTITUDE],
                                                   "each filter minus {base} on the same "
                                                   "data")),
    ]


# --------------------------------------------------------------------------- the report's

def plot_errors_xyz(result: CampaignResult, path: Path) -> None:
    """``errors_xyz.png``: one row per filter, x / y / z error vs time, run 0 with its ±2σ,
    the Monte Carlo envelope, the smoother and the paper's ranges."""
    error_grid_figure(POSITION, "position error (run 0 with its ±2σ; Monte Carlo "
                      "envelope)", paper=quoted_position_range, colours=drone_colours)(
        result, path)


def plot_attitude(result: CampaignResult, path: Path) -> None:
    """``attitude.png``: one row per filter, roll / pitch / yaw error (deg, Z-Y-X) vs time."""
    error_grid_figure(ATTITUDE, "attitude error, Z-Y-X Euler (run 0 with its ±2σ; Monte "
                      "Carlo envelope)", colours=drone_colours)(result, path)


def plot_drift(result: CampaignResult, path: Path) -> None:
    """``drift.png``: median and 90 % quantile of the position error norm vs time."""
    first = run0(result)
    colours = drone_colours(result)
    t = first.times
    fig, ax = plt.subplots(figsize=(10.5, 4.6))
    inch_layout(fig, 1, 1, left=0.75, top=0.3, bottom=0.5)
    for name in [IMU_ONLY, *filter_names(result), REFERENCE]:
        scores = good_scores(result, name)
        if not scores:
            continue
        norm = np.stack([np.linalg.norm(s.err_pos, axis=1) for s in scores])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            med, q90 = np.nanmedian(norm, axis=0), np.nanquantile(norm, 0.9, axis=0)
        c = colours[name]
        ax.plot(t, med, color=c, lw=1.0, label=name)
        ax.plot(t, q90, color=c, lw=0.6, ls=":")
    for end in (result.summary.get("flight") or {}).get("loop_end_times_s", [])[:-1]:
        ax.axvline(end, color="0.4", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_ylim(bottom=1e-3)  # the start is known exactly in the default worlds
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|position error| (m)")
    ax.set_title(titled(result, "drift (solid: median, dotted: 90 %; dashed line: end of loop 1)"),
                 fontsize=10)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=8, frameon=False, ncols=3)
    save(fig, path)


def plot_view3d(result: CampaignResult, path: Path) -> None:
    """``view3d.png``: terrain surface, landmarks, true / filtered / smoothed paths."""
    first = run0(result)
    colours = drone_colours(result)
    world = result.world
    xmin, xmax, ymin, ymax = world.map.bounds_m
    terrain = result_terrain(result)
    gx = np.linspace(xmin, xmax, 41)
    gy = np.linspace(ymin, ymax, 41)
    X, Y = np.meshgrid(gx, gy)
    Z = terrain.height(np.stack([X, Y], axis=-1))
    fig = plt.figure(figsize=(10.5, 8.0))
    inch_layout(fig, 1, 1, left=0.1, right=0.1, top=0.3, bottom=0.0)
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(X, Y, Z, cmap="YlGn_r", alpha=0.45, linewidth=0, antialiased=True)
    truth = first.truth
    ax.plot(truth[:, 0], truth[:, 1], truth[:, 2], color="black", lw=1.6, label="true path")
    for name in [*filter_names(result), REFERENCE]:
        tr = first.tracks.get(name)
        if tr is None:
            continue
        ax.plot(tr.p[:, 0], tr.p[:, 1], tr.p[:, 2], color=colours[name], lw=0.9,
                ls="--" if name == REFERENCE else "-", label=name)
        if len(tr.landmarks):
            ax.scatter(tr.landmarks[:, 0], tr.landmarks[:, 1], tr.landmarks[:, 2], marker="+",
                       s=40, color=colours[name])
    lm = first.true_landmarks
    ax.scatter(lm[:, 0], lm[:, 1], lm[:, 2], marker="*", s=120, color="gold",
               edgecolors="black", label="landmarks (true)", depthshade=False)
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_zlabel("z up (m)")
    zmax = max(float(np.nanmax(truth[:, 2])), float(np.nanmax(Z))) + 5.0
    ax.set_zlim(float(np.nanmin(Z)) - 1.0, zmax)
    ax.set_box_aspect((xmax - xmin, ymax - ymin, 3.0 * (zmax - float(np.nanmin(Z)))))
    ax.view_init(elev=35, azim=-60)
    ax.legend(fontsize=8, loc="upper left", frameon=False)
    ax.set_title(titled(result, "run 0"), fontsize=11)
    save(fig, path)


def figure_specs() -> list[FigureSpec]:
    """The drone report's figures, in report order."""
    own = [FigureSpec("errors_xyz.png", "x / y / z error (m) vs time, one row per filter: "
                      "run 0 with its ±2σ, the Monte Carlo envelope (min/max over all "
                      "runs), the smoother's run 0 and the paper's ranges (dashed) where "
                      "quoted.", plot_errors_xyz),
           FigureSpec("attitude.png", "Roll / pitch / yaw error (deg; Z-Y-X Euler angles of "
                      "q_nb, forward-left-up body, pitch positive nose-down) vs time: run 0 "
                      "with its ±2σ, the Monte Carlo envelope, the smoother's run 0.",
                      plot_attitude)]
    tail = [FigureSpec("drift.png", "Position error norm vs time (run median solid, 90 % "
                       "quantile dotted): IMU-only dead reckoning drifts, the SLAM filters "
                       "stay bounded.", plot_drift),
            FigureSpec("view3d.png", "Run 0 in 3-D: terrain, landmarks, true, filtered and "
                       "smoothed paths (also in scene.glb).", plot_view3d)]
    return own + shared_specs() + tail


def figures() -> dict[str, tuple[Any, str]]:
    """File name -> (function drawing it, caption), for
    :class:`~slam.render.document.KindReport` (named lazily by the report)."""
    return figure_table(figure_specs())
