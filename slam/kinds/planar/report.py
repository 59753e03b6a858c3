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

The figures are drawn by :mod:`slam.kinds.planar.figures`, which the report names lazily.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from slam.kind import Deferred
from slam.render.decision import decision_sections, decision_text
from slam.render.document import KindReport, Link, Section, paper_ranges_section
from slam.render.output import tum_header, tum_names, write_tum
from slam.render.output import tum_text as tum_lines
from slam.render.tables import (
    DIVERGED_SHORT,
    ESTIMATOR,
    NIS,
    Column,
    Table,
    band_note,
    consistency_columns,
    consistency_rule,
    epoch_time,
    slam_table,
    terminal_text,
    value,
)
from slam.results import Array, CampaignResult

TIME = Column("time/epoch (µs)", value("time_per_step_s", ".1f", 1e6))

RESULTS = slam_table("xy", Column("heading RMSE (deg)", value("heading_rmse_deg", ".2f")),
                     consistency_columns(), TIME)
"""The report's results table (every column)."""

COMPACT = Table((ESTIMATOR, Column("pos RMSE\n(m)", value("pos_rmse_m", ".3f")),
                 Column("heading\nRMSE (deg)", value("heading_rmse_deg", ".2f")),
                 Column("landmark\nRMSE (m)", value("landmark_rmse_m", ".3f")),
                 *consistency_columns(band=False, headers=("ANEES", "in\nband", "verdict")),
                 NIS, epoch_time("time_per_step_s"),
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
    table = terminal_text(COMPACT, summary,
                          [band_note(summary), "x / y error ranges and figures: report.html"])
    return table + "\n\n" + decision_text(summary)


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
    head, *rest = decision_sections(summary) or [None]
    return [s for s in (head, Section("Results", RESULTS.header, result_rows(summary)), *rest,
                        paper, Section("How to read this", text=HOW_TO_READ)) if s is not None]


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


REPORT = KindReport("planar SLAM campaign", planar_sections,
                    Deferred("slam.kinds.planar.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The planar SLAM kind's report."""
