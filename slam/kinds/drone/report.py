"""Reports of a drone SINS/SLAM campaign: tables, figures, a 3-D scene and trajectories.

:func:`write_drone_outputs` renders a :class:`~slam.results.CampaignResult` of a
``drone-slam`` world into a fresh temporary folder next to the output folder and swaps it
into place (as :func:`slam.report.write_outputs` does for planar worlds):

    summary.json        the summary dict as strict JSON
    report.md / .html   results table, paper-vs-ours x/y/z error ranges, notes, figures
    errors_xyz.png      x / y / z error vs time per filter: run 0, its ±2σ, the Monte
                        Carlo envelope, the smoother's run 0, the paper's ranges
    attitude.png        roll / pitch / yaw error vs time per filter (run 0, ±2σ, envelope)
    nees.png            run-averaged position NEES / 3 and pose NEES / 6 vs their bands
    drift.png           position error norm vs time: IMU only vs the filters vs the smoother
    view3d.png          terrain surface, landmarks, true / filtered / smoothed paths (run 0)
    scene.glb           the same scene as a glTF binary (terrain mesh, landmark markers,
                        paths as tubes): :func:`write_scene_glb`
    <name>.tum          run 0's trajectories (``t x y z qx qy qz qw``) and ``truth.tum``

:func:`drone_figures` draws the PNG figures alone, :func:`write_scene_glb` the glTF
scene; :func:`drone_text_table` is the plain-text results table for the command line.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from slam.render.document import KindReport, Section  # noqa: E402
from slam.render.plotting import envelope, good_scores, run0, save  # noqa: E402
from slam.render.tables import (  # noqa: E402
    MISSING,
    estimator_entries,
    interval,
    markdown_table,
    num,
    paper_range,
    paper_rows,
    plain_table,
)
from slam.results import REFERENCE, CampaignResult  # noqa: E402

IMU_ONLY = "imu_only"
_FILTER_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:brown",
                   "tab:pink", "tab:olive", "tab:cyan")
_REF_COLOUR = "#7a3b8f"
_IMU_COLOUR = "0.55"
_AXES = ("x", "y", "z")
_ATT = ("roll", "pitch", "yaw")

COLUMNS = ("estimator", "pos RMSE (m)", "x range (m)", "y range (m)", "z range (m)",
           "roll/pitch/yaw RMSE (deg)", "landmark RMSE (m)", "ANEES pos [95 % band]",
           "ANEES pose [95 % band]", "NIS/dof", "time/step (ms)", "diverged runs")


# --------------------------------------------------------------------------- tables

def _band_cell(entry: dict[str, Any], key: str, band: str) -> str:
    value = num(entry.get(key), ".2f")
    if value == MISSING:
        return MISSING
    b = interval(entry.get(band), ".2f")
    return value if b == MISSING else f"{value} {b}"


def _row(name: str, e: dict[str, Any]) -> list[str]:
    ranges = e.get("pos_err_range_m") or {}
    att = e.get("att_rmse_deg") or {}
    att_cell = "/".join(num(att.get(a), ".3f") for a in _ATT) if att else MISSING
    scored, diverged = e.get("runs_scored"), e.get("diverged_runs")
    runs = "" if scored is None or diverged is None else f"/{scored + diverged}"
    return [
        name,
        num(e.get("pos_rmse_m"), ".3f"),
        *(interval(ranges.get(a)) for a in _AXES),
        att_cell,
        num(e.get("landmark_rmse_m"), ".3f"),
        _band_cell(e, "anees", "anees_bounds_95"),
        _band_cell(e, "anees_pose6", "anees_pose6_bounds_95"),
        num(e.get("nis_mean"), ".2f"),
        num(e.get("time_per_step_s"), ".2f", 1e3),
        MISSING if diverged is None else f"{diverged}{runs}",
    ]


def drone_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Filters, then the IMU-only baseline and the GTSAM smoother."""
    return [_row(n, e) for n, e in estimator_entries(summary)]


def drone_results_table(summary: dict[str, Any]) -> str:
    """The results table in Markdown."""
    return markdown_table(COLUMNS, drone_rows(summary))


def drone_text_table(summary: dict[str, Any]) -> str:
    """The results table as aligned plain text (for the terminal)."""
    return plain_table(COLUMNS, drone_rows(summary))


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
    "1 and stays inside the bracketed 95 % band of the run average. NIS/dof checks the "
    "landmark innovations. `imu_only` is pure strapdown mechanisation from the initial "
    "state with zero bias estimates (no landmarks): the drift the SLAM fusion must bound. "
    "`gtsam` is the batch smoother (iSAM2 + Levenberg-Marquardt, combined IMU factors and "
    "3-D bearing-range factors) on the very same measurements."
)

CAPTIONS = {
    "errors_xyz.png": "x / y / z error vs time: run 0 with its ±2σ, the Monte Carlo "
                      "envelope, the smoother's run 0 and the paper's ranges (dashed).",
    "attitude.png": "Roll / pitch / yaw error vs time: run 0 with its ±2σ and the Monte "
                    "Carlo envelope.",
    "nees.png": "Run-averaged position NEES / 3 and pose NEES / 6 against their 95 % bands.",
    "drift.png": "Position error norm vs time (run median and 90 % quantile): IMU only "
                 "drifts, the SLAM filters stay bounded.",
    "view3d.png": "Run 0 in 3-D: terrain, landmarks, true, filtered and smoothed paths.",
}


def _paper_note(summary: dict[str, Any]) -> str:
    source = (summary.get("paper") or {}).get("source")
    return ("The paper's ranges were read off its figures, so they are approximate"
            + (f" (source: {source})." if source else ".")
            + " Ours are the minimum and maximum error over every epoch of every run that "
              "did not diverge.")


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
    out = [Section("Results", COLUMNS, drone_rows(summary), _flight_note(summary))]
    header, rows = paper_rows(summary)
    out.append(Section("Paper vs ours: drone position error ranges", header, rows,
                       _paper_note(summary)) if rows else
               Section("Paper vs ours: drone position error ranges",
                       text="The world file quotes no error ranges from a paper."))
    dh, dr = drift_rows(summary)
    if len(dh) > 1:
        out.append(Section("Drift: position error per loop", dh, dr,
                           "Bounded SLAM error shows as loop 2 no worse than loop 1; the "
                           "IMU-only error grows without bound."))
    out.append(Section("How to read this", text=HOW_TO_READ))
    return out


def drone_report_markdown(summary: dict[str, Any]) -> str:
    """The sections as Markdown (tables and notes, no figures)."""
    parts = []
    for sec in drone_sections(summary):
        parts += [f"## {sec.title}", ""]
        if sec.header is not None:
            parts += [markdown_table(sec.header, sec.rows), ""]
        if sec.text:
            parts += [sec.text, ""]
    return "\n".join(parts)


# --------------------------------------------------------------------------- figures

def _filters(result: CampaignResult) -> list[str]:
    return list((result.summary.get("filters") or {}).keys())


def _colours(result: CampaignResult) -> dict[str, str]:
    out = {n: _FILTER_COLOURS[i % len(_FILTER_COLOURS)] for i, n in enumerate(_filters(result))}
    out[REFERENCE] = _REF_COLOUR
    out[IMU_ONLY] = _IMU_COLOUR
    return out


def _error_grid(result: CampaignResult, path: Path, attr: str, sig: str, labels: Sequence[str],
                unit: str, scale: float, paper: bool, title: str) -> None:
    first = run0(result)
    names = _filters(result)
    colours = _colours(result)
    t = first.times
    fig, axes = plt.subplots(len(names), 3, figsize=(13.0, 1.3 + 1.9 * len(names)),
                             sharex=True, squeeze=False, layout="constrained")
    ref = first.scores.get(REFERENCE)
    lim = np.zeros(3)
    for row, name in enumerate(names):
        c = colours[name]
        sc0 = first.scores.get(name)
        for col, axis in enumerate(labels):
            ax = axes[row, col]
            env = envelope(good_scores(result, name),
                           lambda s, a=attr, c=col: getattr(s, a)[:, c] * scale)
            if env is not None:
                ax.fill_between(t, env[0], env[1], color=c, alpha=0.15, lw=0)
                lim[col] = max(lim[col], float(np.nanmax(np.abs(env))))
            if sc0 is not None and not sc0.diverged:
                sd = getattr(sc0, sig)[:, col] * scale
                ax.plot(t, 2 * sd, color=c, lw=0.7, alpha=0.55)
                ax.plot(t, -2 * sd, color=c, lw=0.7, alpha=0.55)
                ax.plot(t, getattr(sc0, attr)[:, col] * scale, color=c, lw=1.0)
            elif col == 0:
                ax.text(0.01, 0.95, "diverged on run 0", transform=ax.transAxes, va="top",
                        fontsize=8, color=c)
            if ref is not None and not ref.diverged:
                ax.plot(t, getattr(ref, attr)[:, col] * scale, color=_REF_COLOUR, lw=0.7,
                        alpha=0.8)
            if paper:
                pr = paper_range(result.summary, name, axis)
                if pr is not None:
                    for v in pr:
                        ax.axhline(v, color=c, ls="--", lw=1.2)
                    lim[col] = max(lim[col], *map(abs, pr))
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.grid(True, lw=0.3, alpha=0.5)
            ax.set_ylabel(f"{name}: {axis} ({unit})", fontsize=9)
            if row == 0:
                ax.set_title(f"{axis} error", fontsize=10)
            if row == len(names) - 1:
                ax.set_xlabel("time (s)")
    for col in range(3):
        if lim[col] > 0:
            for row in range(len(names)):
                axes[row, col].set_ylim(-1.15 * lim[col], 1.15 * lim[col])
    legend = [Line2D([], [], color="0.2", lw=1.0, label="run 0 error"),
              Line2D([], [], color="0.2", lw=0.7, alpha=0.55, label="run 0 ±2σ"),
              Patch(fc="0.2", alpha=0.15, label="Monte Carlo envelope (min/max)"),
              Line2D([], [], color=_REF_COLOUR, lw=0.7, label="gtsam run 0 error")]
    if paper:
        legend.append(Line2D([], [], color="0.2", ls="--", lw=1.2, label="paper's range"))
    fig.legend(handles=legend, loc="outside lower center", fontsize=8, ncols=len(legend),
               frameon=False)
    fig.suptitle(f"{result.summary.get('world', '')}: {title}", fontsize=11)
    save(fig, path)


def plot_errors_xyz(result: CampaignResult, path: Path) -> None:
    """``errors_xyz.png``: one row per filter, x / y / z error vs time."""
    _error_grid(result, path, "err_pos", "sig_pos", _AXES, "m", 1.0, True,
                "drone position error")


def plot_attitude(result: CampaignResult, path: Path) -> None:
    """``attitude.png``: one row per filter, roll / pitch / yaw error (deg) vs time."""
    _error_grid(result, path, "err_att", "sig_att", _ATT, "deg", 180.0 / math.pi, False,
                "attitude error")


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png``: run-averaged position NEES / 3 and pose NEES / 6 vs time."""
    first = run0(result)
    colours = _colours(result)
    t = first.times
    fig, axes = plt.subplots(1, 2, figsize=(13.0, 4.6), layout="constrained", sharey=True)
    for ax, attr, dof, key, band_key, label in (
            (axes[0], "nees_pos", 3, "anees", "anees_bounds_95", "position NEES / 3"),
            (axes[1], "nees_pose", 6, "anees_pose6", "anees_pose6_bounds_95",
             "pose NEES / 6")):
        band = None
        for name in [*_filters(result), REFERENCE]:
            scores = good_scores(result, name)
            if not scores:
                continue
            nees = np.stack([getattr(s, attr) for s in scores])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                mean = np.nanmean(nees, axis=0) / dof
            mean[~(mean > 0.0)] = np.nan
            group = "reference" if name == REFERENCE else "filters"
            entry = (result.summary.get(group) or {}).get(name) or {}
            value = entry.get(key)
            ax.plot(t, mean, color=colours[name], lw=0.8, alpha=0.85,
                    label=name if value is None else f"{name} ({value:.2f})")
            band = band or entry.get(band_key)
        if band:
            ax.axhline(band[0], color="black", ls="--", lw=1.1, label="95 % band")
            ax.axhline(band[1], color="black", ls="--", lw=1.1)
        ax.axhline(1.0, color="0.5", lw=0.6)
        ax.set_yscale("log")
        ax.set_xlabel("time (s)")
        ax.set_title(label, fontsize=10)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, frameon=False)
    fig.suptitle(f"{result.summary.get('world', '')}: consistency (run average)", fontsize=11)
    save(fig, path)


def plot_drift(result: CampaignResult, path: Path) -> None:
    """``drift.png``: median and 90 % quantile of the position error norm vs time."""
    first = run0(result)
    colours = _colours(result)
    t = first.times
    fig, ax = plt.subplots(figsize=(10.5, 4.6), layout="constrained")
    for name in [IMU_ONLY, *_filters(result), REFERENCE]:
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
    ax.set_title(f"{result.summary.get('world', '')}: drift (solid: median, dotted: 90 %; "
                 "dashed line: end of loop 1)", fontsize=10)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=8, frameon=False, ncols=3)
    save(fig, path)


def _terrain(result: CampaignResult):
    from slam.kinds.drone.run import terrain_of

    return terrain_of(result.world)


def plot_view3d(result: CampaignResult, path: Path) -> None:
    """``view3d.png``: terrain surface, landmarks, true / filtered / smoothed paths."""
    first = run0(result)
    colours = _colours(result)
    world = result.world
    xmin, xmax, ymin, ymax = world.map.bounds_m
    terrain = _terrain(result)
    gx = np.linspace(xmin, xmax, 41)
    gy = np.linspace(ymin, ymax, 41)
    X, Y = np.meshgrid(gx, gy)
    Z = terrain.height(np.stack([X, Y], axis=-1))
    fig = plt.figure(figsize=(10.5, 8.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(X, Y, Z, cmap="YlGn_r", alpha=0.45, linewidth=0, antialiased=True)
    truth = first.truth
    ax.plot(truth[:, 0], truth[:, 1], truth[:, 2], color="black", lw=1.6, label="true path")
    for name in [*_filters(result), REFERENCE]:
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
    ax.set_title(f"{result.summary.get('world', '')}: run 0", fontsize=11)
    save(fig, path)


FIGURES = {"errors_xyz.png": plot_errors_xyz, "attitude.png": plot_attitude,
           "nees.png": plot_nees, "drift.png": plot_drift, "view3d.png": plot_view3d}


def drone_figure_table() -> dict[str, tuple[Any, str]]:
    """File name -> (function drawing it, caption), for :class:`~slam.report.KindReport`."""
    return {name: (fn, CAPTIONS[name]) for name, fn in FIGURES.items()}


def drone_figures(result: CampaignResult, out_dir: str | Path) -> list[str]:
    """Draw every PNG figure into ``out_dir``; returns the file names."""
    out_dir = Path(out_dir)
    for name, fn in FIGURES.items():
        fn(result, out_dir / name)
    return list(FIGURES)


# --------------------------------------------------------------------------- 3-D scene

def tube(points: np.ndarray, radius: float, sides: int = 6):
    """A closed-ring tube mesh along the polyline ``points`` (P, 3) (NaN rows dropped)."""
    import trimesh

    pts = np.asarray(points, dtype=float)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    pts = pts[keep]
    if len(pts) < 2:
        return None
    t = np.gradient(pts, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    ref = np.where(np.abs(t[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    n1 = np.cross(t, ref)
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    n2 = np.cross(t, n1)
    ang = 2.0 * np.pi * np.arange(sides) / sides
    ring = (np.cos(ang)[None, :, None] * n1[:, None] + np.sin(ang)[None, :, None] * n2[:, None])
    verts = (pts[:, None] + radius * ring).reshape(-1, 3)
    i = np.arange(len(pts) - 1)[:, None]
    j = np.arange(sides)[None, :]
    a, b = i * sides + j, i * sides + (j + 1) % sides
    c, d = a + sides, b + sides
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                            np.stack([a, d, c], -1).reshape(-1, 3)])
    return trimesh.Trimesh(verts, faces, process=False)


def _rgba(colour: str, alpha: float = 1.0) -> list[int]:
    from matplotlib.colors import to_rgba

    r, g, b, _ = to_rgba(colour)
    return [int(255 * r), int(255 * g), int(255 * b), int(255 * alpha)]


def write_scene_glb(result: CampaignResult, path: str | Path) -> Path:
    """``scene.glb``: terrain mesh, true landmarks (gold spheres), each estimator's final
    landmarks (small spheres in its colour) and run 0's paths as tubes."""
    import trimesh

    first = run0(result)
    colours = _colours(result)
    scene = trimesh.Scene()
    ground = _terrain(result).mesh.copy()
    z = ground.vertices[:, 2]
    span = max(float(np.ptp(z)), 1e-9)
    shade = ((z - z.min()) / span)[:, None]
    low, high = np.array(_rgba("#6b8e23")), np.array(_rgba("#c2b280"))
    ground.visual.vertex_colors = (low + shade * (high - low)).astype(np.uint8)
    scene.add_geometry(ground, node_name="terrain", geom_name="terrain")
    for i, p in enumerate(first.true_landmarks):
        s = trimesh.creation.icosphere(subdivisions=1, radius=0.8)
        s.apply_translation(p)
        s.visual.face_colors = _rgba("gold")
        scene.add_geometry(s, node_name=f"landmark_{i}", geom_name=f"landmark_{i}")
    paths = [("truth", first.truth[:, :3], "black", 0.18)]
    for name in [*_filters(result), REFERENCE]:
        tr = first.tracks.get(name)
        if tr is not None:
            paths.append((name, tr.p, colours[name], 0.12))
            for j, p in zip(tr.landmark_ids, tr.landmarks):
                s = trimesh.creation.icosphere(subdivisions=1, radius=0.35)
                s.apply_translation(p)
                s.visual.face_colors = _rgba(colours[name])
                label = f"{name}_landmark_{int(j)}"
                scene.add_geometry(s, node_name=label, geom_name=label)
    for name, pts, colour, radius in paths:
        mesh = tube(pts, radius)
        if mesh is not None:
            mesh.visual.face_colors = _rgba(colour)
            scene.add_geometry(mesh, node_name=f"path_{name}", geom_name=f"path_{name}")
    path = Path(path)
    path.write_bytes(scene.export(file_type="glb"))
    return path


# --------------------------------------------------------------------------- TUM, writing

def tum_text_3d(times: np.ndarray, p: np.ndarray, q: np.ndarray) -> str:
    """TUM lines ``t x y z qx qy qz qw`` (scalar-last), non-finite rows left out."""
    ok = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(q), axis=1)
    rows = np.column_stack([times[ok], p[ok], q[ok][:, 1:], q[ok][:, :1]])
    return "".join(f"{r[0]:.6f} " + " ".join(f"{v:.9g}" for v in r[1:]) + "\n" for r in rows)


def write_tum_3d(result: CampaignResult, out_dir: Path) -> list[str]:
    first = result.outcomes[0]
    if first.truth is None or first.times is None:
        return []
    written = []
    items = [("truth", first.truth[:, :3], first.truth[:, 6:10]),
             *((n, tr.p, tr.q) for n, tr in first.tracks.items())]
    for name, p, q in items:
        (out_dir / f"{name}.tum").write_text(tum_text_3d(first.times, p, q), encoding="utf-8")
        written.append(f"{name}.tum")
    return written


def drone_extra_files(result: CampaignResult, out_dir: Path) -> list[str]:
    """``scene.glb`` and the TUM trajectories of run 0."""
    out_dir = Path(out_dir)
    written = []
    if result.outcomes and result.outcomes[0].tracks:
        write_scene_glb(result, out_dir / "scene.glb")
        written.append("scene.glb")
    return written + write_tum_3d(result, out_dir)


REPORT = KindReport("quaternion SINS/SLAM campaign", drone_sections, drone_figure_table,
                    drone_text_table, drone_extra_files)

