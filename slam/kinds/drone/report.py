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

:func:`drone_figures` draws the PNG figures alone, :mod:`slam.kinds.drone.scene` the glTF
scene and the trajectories, :mod:`slam.kinds.drone.figures` the figure specs;
:func:`drone_text_table` is the compact results table for the command line.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.drone.figures import ATTITUDE, POSITION, shared_specs
from slam.kinds.drone.scene import (
    IMU_ONLY,
    drone_colours,
    result_terrain,
    write_scene_glb,
    write_tum_3d,
)
from slam.render.document import KindReport, Link, Section, paper_ranges_section
from slam.render.figures import (
    FigureSpec,
    error_grid_figure,
    figure_table,
    quoted_position_range,
)
from slam.render.output import tum_names
from slam.render.plotting import (
    filter_names,
    good_scores,
    plt,
    run0,
    save,
    titled,
)
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
    error_range,
    num,
    terminal_text,
    value,
)
from slam.results import REFERENCE, CampaignResult

_AXES = ("x", "y", "z")
_ATT = ("roll", "pitch", "yaw")


# --------------------------------------------------------------------------- tables

def _attitude_cell(name: str, e: dict[str, Any]) -> str:
    att = e.get("att_rmse_deg") or {}
    return "/".join(num(att.get(a), ".3f") for a in _ATT) if att else MISSING


TABLE = Table((ESTIMATOR, POS_RMSE, *map(error_range, _AXES),
               Column("roll/pitch/yaw RMSE (deg)", _attitude_cell), LANDMARK_RMSE,
               Column("time/epoch (ms)", value("time_per_step_s", ".2f", 1e3)), DIVERGED))
"""The report's results table: accuracy and time."""

CONSISTENCY = Table((ESTIMATOR, *consistency_columns("anees", "position"),
                     *consistency_columns("anees_pose6", "pose"), NIS))
"""The report's consistency table: position and pose ANEES, fraction of epochs in band,
verdict, NIS."""

COMPACT = Table((ESTIMATOR, Column("pos RMSE\n(m)", value("pos_rmse_m", ".3f")),
                 Column("yaw RMSE\n(deg)", value("heading_rmse_deg", ".3f")),
                 Column("landmark\nRMSE (m)", value("landmark_rmse_m", ".3f")),
                 *consistency_columns(band=False, headers=("ANEES\npos", "in\nband",
                                                           "verdict")),
                 Column("ANEES\npose", value("anees_pose6", ".2f")),
                 Column("time/epoch\n(ms)", value("time_per_step_s", ".2f", 1e3)),
                 DIVERGED_SHORT))
"""The terminal table: fits 100 columns (ranges, roll / pitch and the pose verdict are in
the report)."""


def drone_text_table(summary: dict[str, Any]) -> str:
    """The compact terminal table, failure reasons and the ANEES band (≤ 100 columns)."""
    return terminal_text(COMPACT, summary, [
        band_note(summary, what="position ANEES"),
        "ANEES pose: 6-dof [position, attitude] NEES / 6; ranges, roll / pitch RMSE and "
        "the pose verdict: report.html"])


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
    """Results, the paper's x/y/z ranges next to ours, per-loop drift, how to read."""
    out = [Section("Results", TABLE.header, TABLE.rows(summary), _flight_note(summary)),
           Section("Consistency", CONSISTENCY.header, CONSISTENCY.rows(summary),
                   consistency_rule()),
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


# --------------------------------------------------------------------------- figures

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
    fig, ax = plt.subplots(figsize=(10.5, 4.6), layout="constrained")
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
    fig = plt.figure(figsize=(10.5, 8.0), layout="constrained")
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


def drone_figure_table() -> dict[str, tuple[Any, str]]:
    """File name -> (function drawing it, caption), for
    :class:`~slam.render.document.KindReport`."""
    return figure_table(figure_specs())


def drone_figures(result: CampaignResult, out_dir: str | Path) -> list[str]:
    """Draw every PNG figure into ``out_dir``; returns the file names."""
    out_dir = Path(out_dir)
    specs = figure_specs()
    for spec in specs:
        spec.draw(result, out_dir / spec.name)
    return [spec.name for spec in specs]


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
    return [("scene.glb", "run 0 in 3-D (glTF binary: terrain, landmarks, paths)"),
            *((f"{n}.tum", f"run 0's {'true' if n == 'truth' else n} trajectory (TUM: t x y "
               "z qx qy qz qw)") for n in tum_names(result))]


REPORT = KindReport("quaternion SINS/SLAM campaign", drone_sections, drone_figure_table,
                    drone_text_table, drone_extra_files, drone_links)

