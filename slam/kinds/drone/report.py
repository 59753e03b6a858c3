"""Reports of a drone SINS/SLAM campaign: tables, figures, a 3-D scene and trajectories.

The report folder of a ``drone-slam`` world (written by
:func:`slam.render.output.write_outputs` from :data:`REPORT`):

    summary.json        the summary dict as strict JSON
    report.md / .html   results table, paper-vs-ours x/y/z error ranges, notes, figures
    errors_xyz.png      x / y / z error vs time per filter: run 0, its ±2σ, the Monte
                        Carlo envelope, the smoother's run 0, the paper's ranges
    attitude.png        roll / pitch / yaw error (Z-Y-X Euler) vs time per filter
    rmse_sigma.png      Monte Carlo RMSE vs the RMS of the own σ: position, velocity,
                        attitude, along- / cross-track
    bias.png            run 0's gyro and accelerometer bias estimates vs truth, ±2σ
    nees.png            position, pose and attitude NEES and the NIS vs time in their
                        bands; per-run histograms
    landmarks.png       landmark RMSE / NEES, landmarks in the state, map covariance trace
    differences.png     each filter minus SRCKF on the same runs
    drift.png           position error norm vs time: IMU only vs the filters vs the smoother
    view3d.png          terrain surface, landmarks, true / filtered / smoothed paths (run 0)
    scene.glb           the same scene as a glTF binary (terrain mesh, landmark markers,
                        paths as tubes): :func:`~slam.kinds.drone.scene.write_scene_glb`
    <name>.tum          run 0's trajectories (``t x y z qx qy qz qw``) and ``truth.tum``

:mod:`slam.kinds.drone.figures` draws the PNG figures (named lazily: a run without figures
never imports matplotlib), :mod:`slam.kinds.drone.scene` the glTF scene and the
trajectories; :func:`drone_text_table` is the compact results table for the command line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from slam.kind import Deferred
from slam.kinds.drone.scene import write_scene_glb, write_tum_3d
from slam.render.decision import decision_sections, decision_text, rank_column
from slam.render.document import KindReport, Link, Section, paper_ranges_section
from slam.render.tables import (
    DIVERGED,
    DIVERGED_SHORT,
    ESTIMATOR,
    LANDMARK_RMSE,
    MISSING,
    NIS,
    POS_RMSE,
    Column,
    Table,
    band_note,
    consistency_columns,
    consistency_rule,
    epoch_time,
    error_range,
    landmark_anees_rule,
    num,
    terminal_text,
    value,
)
from slam.render.tables import smoother_cost as tables_smoother_cost
from slam.results import REFERENCE, CampaignResult

_AXES = ("x", "y", "z")
_ATT = ("roll", "pitch", "yaw")


# --------------------------------------------------------------------------- tables

def _attitude_cell(name: str, e: dict[str, Any]) -> str:
    att = e.get("att_rmse_deg") or {}
    return "/".join(num(att.get(a), ".3f") for a in _ATT) if att else MISSING


def _run_time(name: str, e: dict[str, Any]) -> str:
    """Wall time per run (s): the filters' and, for the smoother, its solve (the marginals
    are in :func:`smoother_cost`)."""
    return num(e.get("time_s" if name == REFERENCE else "time_per_run_s"), ".2f")


def _epoch_time(name: str, e: dict[str, Any]) -> str:
    """Time per epoch (ms); none for the smoother, a batch solve (its cost is per run)."""
    return MISSING if name == REFERENCE else num(e.get("time_per_step_s"), ".2f", 1e3)


MAP_CONSISTENCY = consistency_columns("landmark_anees", "landmarks")
"""The landmark ANEES with its band, the fraction of epochs in band and the verdict."""


def results_table(summary: dict[str, Any]) -> Table:
    """The report's results table: position rank, accuracy, the map's verdict, time."""
    return Table((ESTIMATOR, rank_column(summary, "position", "rank (pos)"), POS_RMSE,
                  *map(error_range, _AXES), Column("roll/pitch/yaw RMSE (deg)", _attitude_cell),
                  LANDMARK_RMSE, MAP_CONSISTENCY[2], Column("time/epoch (ms)", _epoch_time),
                  Column("s/run", _run_time), DIVERGED))


CONSISTENCY = Table((ESTIMATOR, *consistency_columns("anees", "position"),
                     *consistency_columns("anees_pose6", "pose"), *MAP_CONSISTENCY, NIS))
"""The report's consistency table: position, pose and landmark ANEES, fraction of epochs
in band, verdict, NIS."""


def compact_table(summary: dict[str, Any]) -> Table:
    """The terminal table: fits 100 columns (ranges, roll / pitch, the pose verdict, the
    landmark ANEES and the position rank - in the ranking tables below it - are in the
    report)."""
    return Table((ESTIMATOR, Column("pos RMSE\n(m)", value("pos_rmse_m", ".3f")),
                  Column("yaw RMSE\n(deg)", value("heading_rmse_deg", ".3f")),
                  Column("landmark\nRMSE (m)", value("landmark_rmse_m", ".3f")),
                  *consistency_columns(band=False, headers=("ANEES\npos", "in\nband",
                                                            "verdict")),
                  Column("map\nverdict", MAP_CONSISTENCY[2].cell),
                  epoch_time("time_per_step_s", ".2f"), DIVERGED_SHORT))


def smoother_cost(summary: dict[str, Any]) -> str:
    """The GTSAM smoother's cost in its own unit: seconds per run (solve, marginals)."""
    return tables_smoother_cost(summary, "iSAM2 + Levenberg-Marquardt")


def drone_text_table(summary: dict[str, Any]) -> str:
    """The compact terminal table, failure reasons, the ANEES band and the smoother's cost
    (≤ 100 columns), then the decision (rankings, settings, headline)."""
    table = terminal_text(compact_table(summary), summary, [
        band_note(summary, what="position ANEES"),
        "ANEES pose: 6-dof [position, attitude] NEES / 6; map verdict: the landmark NEES; "
        "ranges, roll / pitch RMSE, the pose and landmark ANEES: report.html",
        smoother_cost(summary)])
    return table + "\n\n" + decision_text(summary)


def drift_rows(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Per-loop position RMSE / max error: bounded error shows as loop 2 ≈ loop 1."""
    header = ["estimator"]
    rows = []
    groups = [*(summary.get("filters") or {}).items(),
              *((summary.get("baselines") or {}).items()),
              *((summary.get("reference") or {}).items())]
    n_loops = max((len(e.get("loop_pos_rmse_m") or []) for _, e in groups), default=0)
    for i in range(n_loops):
        header += [f"loop {i + 1} RMSE (m)", f"loop {i + 1} max (m)"]
    for name, e in groups:
        rm, mx = e.get("loop_pos_rmse_m") or [], e.get("loop_pos_max_err_m") or []
        row = [name]
        for i in range(n_loops):
            row += [num(rm[i] if i < len(rm) else None, ".3f"),
                    num(mx[i] if i < len(mx) else None, ".3f")]
        rows.append(row)
    return header, rows


HOW_TO_READ = (
    "Errors are estimate minus truth of the drone's ENU position; the ranges are the "
    "extreme x / y / z errors over all sensor epochs of all runs that did not diverge. "
    "Attitude errors are Z-Y-X Euler angles of q_nb (forward-left-up body). ANEES pos is "
    "the 3-dof position NEES averaged over runs and epochs and divided by 3; ANEES pose "
    "the 6-dof [position, body-frame attitude] NEES / 6; a consistent filter scores about "
    "1 and its run average stays inside the bracketed 95 % band at about 95 % of the "
    "epochs ('in band'). " + consistency_rule() + " NIS/dof checks the "
    "landmark innovations. `imu_only` is pure strapdown mechanisation from the initial "
    "state with zero bias estimates (no landmarks): the drift the SLAM fusion must bound. "
    "`gtsam` is the batch smoother (iSAM2 + Levenberg-Marquardt, combined IMU factors and "
    "3-D bearing-range factors) on the very same measurements."
)


LANDMARK_NOTE = landmark_anees_rule(3)


def _flight_note(summary: dict[str, Any]) -> str:
    f = summary.get("flight") or {}
    if not f:
        return ""
    return (f"Flights of {f.get('duration_s', 0):.0f} s ({f.get('epochs', '?')} sensor epochs "
            f"at {f.get('sensor_rate_hz', '?')} Hz, IMU at {f.get('imu_rate_hz', '?')} Hz) "
            f"at {f.get('speed_mps', '?')} m/s, {f.get('height_above_ground_m', '?')} m above "
            f"{f.get('terrain', '?')} terrain; time per step is one epoch (prediction through "
            "its IMU samples, batch update, augmentation).")


def drone_sections(summary: dict[str, Any]) -> list[Section]:
    """The headline, results, the rankings and settings, consistency, the paper's x/y/z
    ranges next to ours, per-loop drift, how to read."""
    table = results_table(summary)
    head, *rest = decision_sections(summary) or [None]
    results = Section("Results", table.header, table.rows(summary),
                      f"{_flight_note(summary)} {smoother_cost(summary)}".strip())
    out = [s for s in (head, results, *rest) if s is not None]
    out += [Section("Consistency", CONSISTENCY.header, CONSISTENCY.rows(summary),
                    consistency_rule() + " " + LANDMARK_NOTE),
           paper_ranges_section(summary, "Paper vs ours: drone position error ranges",
                                "Ours are the minimum and maximum error over every epoch of "
                                "every run that did not diverge.")]
    dh, dr = drift_rows(summary)
    if len(dh) > 1:
        out.append(Section("Drift: position error per loop", dh, dr,
                           "Bounded SLAM error shows as loop 2 no worse than loop 1; the "
                           "IMU-only error grows without bound."))
    out.append(Section("How to read this", text=HOW_TO_READ))
    return out


def drone_extra_files(result: CampaignResult, out_dir: Path) -> list[str]:
    """``scene.glb`` and the TUM trajectories of run 0."""
    out_dir = Path(out_dir)
    written = []
    if result.outcomes and result.outcomes[0].tracks:
        write_scene_glb(result, out_dir / "scene.glb")
        written.append("scene.glb")
    return written + write_tum_3d(result, out_dir)


def drone_links(result: CampaignResult) -> list[Link]:
    """The files :func:`drone_extra_files` writes, for the report's file list."""
    first = result.outcomes[0] if result.outcomes else None
    if first is None or not first.tracks:
        return []
    from slam.render import tum

    return [("scene.glb", "run 0 in 3-D (glTF binary: terrain, landmarks, paths)"),
            *tum.links(result, list(first.tracks), "trajectory")]


REPORT = KindReport("quaternion SINS/SLAM campaign", drone_sections,
                    Deferred("slam.kinds.drone.figures:figures"),
                    drone_text_table, drone_extra_files, drone_links)

