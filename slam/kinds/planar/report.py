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

from typing import Any

import numpy as np

from slam.kind import Deferred
from slam.render import tum
from slam.render.decision import decision_sections, decision_text
from slam.render.document import KindReport, Section, paper_ranges_section
from slam.render.output import tum_text as tum_lines
from slam.render.tables import (
    DIVERGED_SHORT,
    ESTIMATOR,
    MISSING,
    Column,
    Table,
    band_note,
    consistency_columns,
    consistency_rule,
    epoch_time,
    landmark_anees_rule,
    num,
    slam_table,
    smoother_cost,
    terminal_text,
    value,
)
from slam.results import REFERENCE, Array


def _epoch_time(name: str, e: dict[str, Any]) -> str:
    """Time per filter epoch (µs); none for the smoother, a batch solve (its cost is per
    run: :func:`~slam.render.tables.smoother_cost`)."""
    return MISSING if name == REFERENCE else num(e.get("time_per_step_s"), ".1f", 1e6)


SMOOTHER = "iSAM2, then Levenberg-Marquardt"
TIME = Column("time/epoch (µs)", _epoch_time)
MAP_CONSISTENCY = consistency_columns("landmark_anees", "landmarks")
"""The landmark ANEES with its band, the fraction of epochs in band and the verdict."""

RESULTS = slam_table("xy", Column("heading RMSE (deg)", value("heading_rmse_deg", ".2f")),
                     (*consistency_columns(), *MAP_CONSISTENCY), TIME)
"""The report's results table (every column)."""

COMPACT = Table((ESTIMATOR, Column("pos RMSE\n(m)", value("pos_rmse_m", ".3f")),
                 Column("heading\n(deg)", value("heading_rmse_deg", ".2f")),
                 Column("landmark\nRMSE (m)", value("landmark_rmse_m", ".3f")),
                 *consistency_columns(band=False, headers=("ANEES", "in\nband", "verdict")),
                 Column("map\nverdict", MAP_CONSISTENCY[2].cell),
                 epoch_time("time_per_step_s"),
                 DIVERGED_SHORT))
"""The terminal table: fits 100 columns (the x / y ranges, the landmark ANEES and the NIS
are in the report; heading is the RMSE, map verdict the landmark NEES's)."""


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter, then the odometry baseline and the GTSAM reference."""
    return RESULTS.rows(summary)


def results_table(summary: dict[str, Any]) -> str:
    """The results table in Markdown: filters, then ``odometry`` and ``gtsam``."""
    return RESULTS.markdown(summary)


def text_table(summary: dict[str, Any]) -> str:
    """The compact terminal table, failure reasons and the ANEES band (≤ 100 columns)."""
    table = terminal_text(COMPACT, summary,
                          [band_note(summary), smoother_cost(summary, SMOOTHER),
                           "x / y error ranges, the landmark ANEES, the NIS and figures: "
                           "report.html"])
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
    "period plus the batch update (wall clock). The online rows, when asked for "
    "([filters] online / fixed_lags_s, --online / --fixed-lag S), use only the "
    "measurements up to each epoch, like a filter: `isam2` is iSAM2's current pose and "
    "its marginal covariance after every epoch - the online optimum (the MAP estimate "
    "given the measurements so far), the yardstick a filter's pose and NEES are judged "
    "against; `fls-<lag>s` is a fixed-lag smoother keeping the poses of the last <lag> "
    "seconds and the whole map. The final map of every estimator is judged against the "
    "smoother, which has used every measurement. The online rows are not ranked. "
    + landmark_anees_rule(2)
)


def _segment_cell(entry: dict[str, Any]) -> str:
    if "anees" not in entry:
        return "—"
    return f"{entry['anees']:.2f} / {100 * entry['in_band']:.0f} % ({entry['epochs']})"


def segments_section(summary: dict[str, Any]) -> Section | None:
    """Pose NEES / 3 per time segment (:mod:`slam.kinds.planar.segments`) and each
    estimator's ratio to the online optimum there."""
    seg = summary.get("segments") or {}
    rows_in = seg.get("estimators") or {}
    if not rows_in:
        return None
    has_ratio = any("ratio_to_isam2" in r for r in rows_in.values())
    header = ["estimator", "before closure", "window after it", "rest"]
    if has_ratio:
        header += ["÷ isam2: before", "window", "rest"]
    rows = []
    for name, r in rows_in.items():
        row = [name, *(_segment_cell(r[k]) for k in ("before", "window", "rest"))]
        if has_ratio:
            ratio = r.get("ratio_to_isam2", {})
            row += [f"{ratio[k]:.2f}" if k in ratio else "—" for k in ("before", "window", "rest")]
        rows.append(row)
    closure = seg.get("closure_epoch_range")
    when = (f"closure at epoch {closure[0]}" if closure and closure[0] == closure[1] else
            f"closure at epochs {closure[0]}-{closure[1]}" if closure else "no loop closure")
    text = (f"ANEES / share of epochs in band (epochs) per segment: {seg['definition']}; "
            f"{when} ({seg['runs_with_closure']} of {summary.get('runs')} runs).")
    return Section("Where the gap sits: NEES / 3 per segment", header, rows, text=text)


def planar_sections(summary: dict[str, Any]) -> list[Section]:
    """Results, the paper's ranges next to ours, and how to read them."""
    paper = paper_ranges_section(
        summary, "Paper vs ours: vehicle position error ranges",
        "Ours are the minimum and maximum x / y error over every epoch of every run that did "
        "not diverge.")
    head, *rest = decision_sections(summary) or [None]
    results = Section("Results", RESULTS.header, result_rows(summary),
                      smoother_cost(summary, SMOOTHER))
    return [s for s in (head, results, segments_section(summary), *rest,
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


def _track(o, name: str):
    """(positions, q_wxyz, pose covariance) of ``name`` on run ``o`` (z = 0, yaw only)."""
    poses = o.truth if name == "truth" else o.tracks[name].poses
    half = 0.5 * poses[:, 2]
    zero = np.zeros(len(poses))
    q = np.column_stack([np.cos(half), zero, zero, np.sin(half)])
    cov = None if name == "truth" else o.tracks[name].pose_cov
    return np.column_stack([poses[:, :2], zero]), q, cov


TUM_NOTE = "x y in the map frame, z = 0, q: the heading about z; poses at the filter epochs"
TUM_COV = "t, then the 3 x 3 covariance of [x, y, heading] row-major (m², m·rad, rad²)"


write_tum_files, tum_links = tum.report_files(_track, TUM_NOTE, TUM_COV, "trajectory")
"""``truth.tum``, ``<name>.tum`` and ``<name>.cov.txt`` of every estimator on each tracked
run (run 0; every run with ``--tum all``: :mod:`slam.render.tum`), and the report's file
list entries for them."""


REPORT = KindReport("planar SLAM campaign", planar_sections,
                    Deferred("slam.kinds.planar.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The planar SLAM kind's report."""
