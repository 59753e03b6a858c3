"""Report of a planar SLAM campaign: results table, paper-vs-ours ranges, figures and TUM
trajectory files.

    map.png          map, paths and landmark estimates of run 0 (2σ ellipses)
    errors_xy.png    x / y / heading error vs time: run 0 and its ±2σ, the Monte Carlo
                     envelope, the smoother's run 0, the paper's ranges
    rmse_sigma.png   Monte Carlo RMSE vs the RMS of the filters' own σ: x, y, heading,
                     along-track, cross-track, horizontal position
    nees.png         pose NEES / 3 and NIS / dof vs time in their bands, the fraction of
                     epochs inside, histograms of the per-run values
    landmarks.png    landmark RMSE, landmark NEES, landmarks in the state, map covariance
                     trace vs time
    differences.png  each filter minus SRCKF on the same runs
    <name>.tum       run 0's trajectory of every estimator, and ``truth.tum`` (TUM format)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.planar.map_figure import plot_map
from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.document import KindReport, Link, Section, paper_ranges_section
from slam.render.figures import (
    FigureSpec,
    differences_figure,
    error_grid_figure,
    figure_table,
    map_figure,
    quoted_position_range,
    rmse_sigma_figure,
)
from slam.render.output import tum_header, tum_names, write_tum
from slam.render.output import tum_text as tum_lines
from slam.render.series import Component
from slam.render.tables import (
    DIVERGED_SHORT,
    ESTIMATOR,
    NIS,
    Column,
    Table,
    band_note,
    consistency_columns,
    consistency_rule,
    slam_table,
    terminal_text,
    value,
)
from slam.results import Array, CampaignResult

DEG = 180.0 / math.pi
TIME = Column("time/epoch (µs)", value("time_per_step_s", ".1f", 1e6))

RESULTS = slam_table("xy", Column("heading RMSE (deg)", value("heading_rmse_deg", ".2f")),
                     consistency_columns(), TIME)
"""The report's results table (every column)."""

COMPACT = Table((ESTIMATOR, Column("pos RMSE\n(m)", value("pos_rmse_m", ".3f")),
                 Column("heading\nRMSE (deg)", value("heading_rmse_deg", ".2f")),
                 Column("landmark\nRMSE (m)", value("landmark_rmse_m", ".3f")),
                 *consistency_columns(band=False, headers=("ANEES", "in\nband", "verdict")),
                 NIS, Column("time/epoch\n(µs)", value("time_per_step_s", ".1f", 1e6)),
                 DIVERGED_SHORT))
"""The terminal table: fits 100 columns (the x / y ranges are in the report)."""


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter, then the odometry baseline and the GTSAM reference."""
    return RESULTS.rows(summary)


def results_table(summary: dict[str, Any]) -> str:
    """The results table in Markdown: filters, then ``odometry`` and ``gtsam``."""
    return RESULTS.markdown(summary)


def text_table(summary: dict[str, Any]) -> str:
    """The compact terminal table, failure reasons and the ANEES band (≤ 100 columns)."""
    return terminal_text(COMPACT, summary,
                         [band_note(summary), "x / y error ranges and figures: report.html"])


HOW_TO_READ = (
    "Errors are estimate minus truth of the vehicle pose; the ranges are the extreme x / y "
    "errors over all epochs and runs. ANEES is the normalised estimation error squared of "
    "the 3-dof pose, averaged over runs and epochs and divided by 3: a consistent filter "
    "scores about 1, and its run-averaged NEES / 3 lies inside the bracketed 95 % band at "
    "about 95 % of the epochs ('in band'). " + consistency_rule() + " "
    "NIS/dof is the same check on the measurement innovations. The `odometry` row is "
    "dead reckoning from the noisy controls alone (no landmarks): what the filters have to "
    "beat. The `gtsam` row is the batch-optimal smoother (GTSAM) on the very same "
    "measurements, using all of them at once: the gap between a filter and it is the "
    "filter's loss. Time per epoch is one filter epoch: the prediction over a sensor "
    "period plus the batch update (wall clock)."
)


def planar_sections(summary: dict[str, Any]) -> list[Section]:
    """Results, the paper's ranges next to ours, and how to read them."""
    paper = paper_ranges_section(
        summary, "Paper vs ours: vehicle position error ranges",
        "Ours are the minimum and maximum x / y error over every epoch of every run that did "
        "not diverge.")
    return [Section("Results", RESULTS.header, result_rows(summary)), paper,
            Section("How to read this", text=HOW_TO_READ)]


# --------------------------------------------------------------------------- figures

def _comp(label: str, unit: str, col: int, scale: float = 1.0) -> Component:
    return Component(label, unit, lambda s: s.err[:, col] * scale,
                     lambda s: s.sigma[:, col] * scale, "position" if col < 2 else "")


def _track(label: str, col: int) -> Component:
    return Component(label, "m", lambda s: s.err_track[:, col] if s.err_track is not None
                     else None,
                     lambda s: s.sig_track[:, col] if s.sig_track is not None else None)


X, Y, HEADING = _comp("x", "m", 0), _comp("y", "m", 1), _comp("heading", "deg", 2, DEG)
HORIZONTAL = Component("horizontal", "m", lambda s: np.hypot(s.err[:, 0], s.err[:, 1]),
                       lambda s: np.hypot(s.sigma[:, 0], s.sigma[:, 1]), "position")
POSE_ROWS = [[X, Y, HEADING], [_track("along-track", 0), _track("cross-track", 1),
                               HORIZONTAL]]

_ERRORS_XY = error_grid_figure([X, Y, HEADING], "vehicle pose error (run 0 with its ±2σ; "
                               "Monte Carlo envelope)", groups=((0, 1), (2,)),
                               paper=quoted_position_range)


def plot_errors_xy(result: CampaignResult, path: Path) -> None:
    """``errors_xy.png``: one row per filter, x / y error (m) and heading error (deg) vs
    time (:func:`~slam.render.figures.error_grid_figure`)."""
    _ERRORS_XY(result, path)


def figure_specs() -> list[FigureSpec]:
    """The planar report's figures (built at call time, so a replaced function is used)."""
    return [
        FigureSpec("map.png", "Run 0: true landmarks, waypoints, true / filtered / smoothed / "
                   "dead-reckoned paths and the final landmark estimates with 2σ ellipses.",
                   plot_map),
        FigureSpec("errors_xy.png", "x and y error (m) and heading error (deg, wrapped) vs "
                   "time, one row per filter: run 0 with its ±2σ band, the Monte Carlo "
                   "envelope (min/max over all runs), the smoother's run 0 and the paper's "
                   "range (dashed) where the paper quotes one.", plot_errors_xy),
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch: x, y, heading; along-track and "
                   "cross-track (in the true heading's frame) and horizontal position. A "
                   "consistent filter's two curves coincide. Odometry is left out (see the "
                   "table).", rmse_sigma_figure(POSE_ROWS, "error vs predicted σ")),
        FigureSpec("nees.png", "Pose NEES / 3 and NIS / dof per epoch (run averages) "
                   "against their 95 % bands (dashed: constant band; grey: a band that "
                   "varies with the number of updates), with the fraction of epochs inside; "
                   "right: histograms of the per-run time averages (1 = consistent).",
                   consistency_figure([NeesSpec("pose NEES / 3", 3, lambda s: s.nees)])),
        FigureSpec("landmarks.png", "The filters' maps per epoch (run averages): RMSE and "
                   "NEES / 2 of the landmarks in the state (against the band), landmarks "
                   "in the state, trace of the map covariance; the smoother's final "
                   "landmark RMSE dashed.", map_figure("the map over time")),
        FigureSpec("differences.png", "Each filter minus the base filter (SRCKF) on the "
                   "same runs (truth cancels): RMS over runs per epoch, with the base "
                   "filter's RMS σ (dotted) for scale.",
                   differences_figure([[X, Y, HEADING]],
                                      "each filter minus {base} on the same data")),
    ]


def planar_figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption)."""
    return figure_table(figure_specs())


def figure_writers() -> dict[str, Callable[[CampaignResult, Path], None]]:
    """File name -> function drawing it."""
    return {s.name: s.draw for s in figure_specs()}


# --------------------------------------------------------------------------- TUM

def tum_text(times: Array, poses: Array, header: str = "") -> str:
    """TUM trajectory lines ``t x y z qx qy qz qw`` for planar poses ``[x, y, φ]``, after
    ``header`` comment lines (``#``).

    z = 0 and the quaternion is the yaw rotation by φ; rows with a non-finite pose
    (a diverged filter) are left out so that tools such as ``evo`` can read the file.
    """
    ok = np.all(np.isfinite(poses), axis=1) & np.isfinite(times)
    t, p = times[ok], poses[ok]
    half = 0.5 * p[:, 2]
    zero = np.zeros(len(t))
    return tum_lines(np.column_stack([t, p[:, 0], p[:, 1], zero, zero, zero, np.sin(half),
                                      np.cos(half)]), header)


def write_tum_files(result: CampaignResult, out_dir: Path) -> list[str]:
    """``truth.tum`` and ``<name>.tum`` for every estimator tracked on run 0."""
    first = result.outcomes[0]
    names = tum_names(result)
    poses = {"truth": first.truth, **{n: tr.poses for n, tr in first.tracks.items()}}
    return write_tum(out_dir, ((n, tum_text(first.times, poses[n], tum_header(result, n)))
                               for n in names))


def tum_links(result: CampaignResult) -> list[Link]:
    """The TUM files :func:`write_tum_files` writes, for the report's file list."""
    return [(f"{n}.tum", f"run 0's {'true' if n == 'truth' else n} trajectory (TUM: t x y z "
             "qx qy qz qw)") for n in tum_names(result)]


REPORT = KindReport("planar SLAM campaign", planar_sections, planar_figures, text_table,
                    write_tum_files, tum_links)
"""The planar SLAM kind's report."""
