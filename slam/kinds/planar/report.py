"""Report of a planar SLAM campaign: results table, paper-vs-ours ranges, map, x/y
errors, NEES and TUM trajectory files.

    map.png        map, paths and landmark estimates of run 0
    errors_xy.png  x / y error vs time: run 0, its ±2σ, the Monte Carlo envelope, the paper
    nees.png       run-averaged NEES / 3 vs time against its 95 % band
    <name>.tum     run 0's trajectory of every estimator, and ``truth.tum`` (TUM format)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.ticker import FormatStrFormatter

from slam.render.document import KindReport, Section, captioned, paper_ranges_section
from slam.render.output import tum_text as tum_lines
from slam.render.output import write_tum
from slam.render.plotting import (
    BASELINE_COLOUR,
    REFERENCE_COLOUR,
    ErrorGrid,
    ErrorPanel,
    covariance_ellipse,
    envelope,
    error_grid,
    filter_names,
    plt,
    run0,
    run_average,
    save,
    titled,
)
from slam.render.plotting import estimator_colours as _colours
from slam.render.plotting import good_scores as _good_scores
from slam.render.tables import (
    Column,
    anees_column,
    paper_range,
    slam_table,
    value,
)
from slam.results import ODOMETRY, REFERENCE, Array, CampaignResult

_TRUTH_STYLE = {"color": "black", "lw": 1.6}
_BASELINE_STYLE = {
    ODOMETRY: {"color": BASELINE_COLOUR, "lw": 1.0, "ls": ":"},
    REFERENCE: {"color": REFERENCE_COLOUR, "lw": 1.2, "ls": "--"},
}


RESULTS = slam_table("xy", Column("heading RMSE (deg)", value("heading_rmse_deg", ".2f")),
                     [anees_column("ANEES [95 % band]")],
                     Column("time/step (µs)", value("time_per_step_s", ".1f", 1e6)))


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter, then the odometry baseline and the GTSAM reference."""
    return RESULTS.rows(summary)


def results_table(summary: dict[str, Any]) -> str:
    """The results table in Markdown: filters, then ``odometry`` and ``gtsam``."""
    return RESULTS.markdown(summary)


HOW_TO_READ = (
    "Errors are estimate minus truth of the vehicle pose; the ranges are the extreme x / y "
    "errors over all steps and runs. ANEES is the normalised estimation error squared of "
    "the 3-dof pose, averaged over runs and steps and divided by 3: a consistent filter "
    "scores about 1, and its run-averaged NEES / 3 lies inside the bracketed 95 % band at "
    "about 95 % of the steps (above the band: overconfident; below: too cautious). "
    "NIS/dof is the same check on the measurement innovations. The `odometry` row is "
    "dead reckoning from the noisy controls alone (no landmarks): what the filters have to "
    "beat. The `gtsam` row is the batch-optimal smoother (GTSAM) on the very same "
    "measurements, using all of them at once: the gap between a filter and it is the "
    "filter's loss."
)

FIGURE_CAPTIONS = {
    "map.png": "Run 0: true landmarks, waypoints, paths and final landmark estimates "
               "(2σ ellipses).",
    "errors_xy.png": "x and y error vs time: run 0 with its ±2σ band, the Monte Carlo "
                     "envelope over all runs, and the paper's ranges (dashed).",
    "nees.png": "Run-averaged NEES / 3 vs time against the 95 % band.",
}


def planar_sections(summary: dict[str, Any]) -> list[Section]:
    """Results, the paper's ranges next to ours, and how to read them."""
    paper = paper_ranges_section(
        summary, "Paper vs ours: vehicle position error ranges",
        "Ours are the minimum and maximum x / y error over every step of every run that did "
        "not diverge.")
    return [Section("Results", RESULTS.header, result_rows(summary)), paper,
            Section("How to read this", text=HOW_TO_READ)]


def planar_figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption); looked up at call time."""
    return captioned(figure_writers(), FIGURE_CAPTIONS)


def estimator_colours(result: CampaignResult) -> dict[str, str]:
    """One colour per filter (tab10 order) plus the baselines' fixed colours."""
    return _colours(filter_names(result), baselines=(ODOMETRY,))


def _landmark_estimators(result: CampaignResult) -> list[str]:
    """Run 0's estimators that estimate landmarks: filters, then the smoother."""
    first = result.outcomes[0]
    return [n for n in [*filter_names(result), REFERENCE]
            if n in first.tracks and len(first.tracks[n].landmarks)]


def _draw_landmark_estimates(ax: plt.Axes, result: CampaignResult, names: Sequence[str],
                             colours: dict[str, str]) -> None:
    """Each estimator's final landmark means (+) and their 2σ ellipses."""
    first = result.outcomes[0]
    for name in names:
        track = first.tracks[name]
        for mean, cov in zip(track.landmarks, track.landmark_cov):
            ell = covariance_ellipse(mean, cov, fc="none", ec=colours[name], lw=1.0, zorder=5)
            if ell is not None:
                ax.add_patch(ell)
        ax.plot(track.landmarks[:, 0], track.landmarks[:, 1], "+", color=colours[name],
                ms=8, mew=1.2, zorder=6)


def _most_uncertain_landmark(result: CampaignResult, names: Sequence[str]) -> int | None:
    """Id of the landmark with the largest 2σ ellipse over the estimators (or None)."""
    first, best, best_id = result.outcomes[0], -1.0, None
    for name in names:
        track = first.tracks[name]
        for lid, cov in zip(track.landmark_ids, track.landmark_cov):
            if lid >= 0 and np.all(np.isfinite(cov)):
                size = float(np.linalg.eigvalsh(0.5 * (cov + cov.T))[-1])
                if size > best:
                    best, best_id = size, int(lid)
    return best_id


def _zoom_half_width(result: CampaignResult, names: Sequence[str], lid: int,
                     centre: Array) -> float:
    first, half = result.outcomes[0], 0.5
    for name in names:
        track = first.tracks[name]
        for i in np.flatnonzero(track.landmark_ids == lid):
            cov = track.landmark_cov[i]
            if np.all(np.isfinite(cov)):
                half = max(half, 2.4 * math.sqrt(max(np.linalg.eigvalsh(cov)[-1], 0.0)))
            half = max(half, 1.3 * float(np.max(np.abs(track.landmarks[i] - centre))))
    return half


def plot_map(result: CampaignResult, path: Path) -> None:
    """``map.png``: the world, run 0's paths and final landmark estimates (2σ ellipses),
    and a zoom on the landmark estimated least certainly (at map scale the estimates sit
    on top of the true landmarks)."""
    first, world = run0(result), result.world
    colours = estimator_colours(result)
    fig = plt.figure(figsize=(11.0, 7.2), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(3.0, 1.2))
    ax = fig.add_subplot(grid[:, 0])
    xmin, xmax, ymin, ymax = world.map.bounds_m
    ax.add_patch(Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False,
                           ec="0.75", lw=0.8))
    wp = world.map.waypoints
    ax.plot(wp[:, 0], wp[:, 1], "s", ms=5, mfc="none", mec="0.45", label="waypoints")
    truth = first.truth
    ax.plot(truth[:, 0], truth[:, 1], label="true path", zorder=2, **_TRUTH_STYLE)
    ax.plot(truth[0, 0], truth[0, 1], "o", color="black", ms=7, label="start", zorder=6)
    for name in [*filter_names(result), ODOMETRY, REFERENCE]:
        track = first.tracks.get(name)
        if track is None:
            continue
        style = _BASELINE_STYLE.get(name, {"color": colours[name], "lw": 0.9, "alpha": 0.9})
        label = {ODOMETRY: "odometry (dead reckoning)",
                 REFERENCE: "gtsam smoother"}.get(name, name)
        ax.plot(track.poses[:, 0], track.poses[:, 1], label=label, zorder=3, **style)
    lm_names = _landmark_estimators(result)
    _draw_landmark_estimates(ax, result, lm_names, colours)
    lm = first.true_landmarks if first.true_landmarks is not None else world.map.landmarks
    star = {"marker": "*", "ls": "none", "color": "black", "mfc": "gold", "mew": 0.8}
    ax.plot(lm[:, 0], lm[:, 1], ms=10, zorder=4, label="landmarks (true)", **star)
    pad = 0.03 * max(xmax - xmin, ymax - ymin)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(titled(result, "run 0"))
    ax.grid(True, lw=0.3, alpha=0.5)

    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], ls="none", marker="+", color="0.3", ms=8, mew=1.2))
    labels.append("landmark estimate\n(+, 2σ ellipse)")
    legend_ax = fig.add_subplot(grid[0, 1])
    legend_ax.axis("off")
    legend_ax.legend(handles, labels, loc="upper left", fontsize=9, frameon=False)

    lid = _most_uncertain_landmark(result, lm_names)
    if lid is not None and 0 <= lid < len(lm):
        zoom = fig.add_subplot(grid[1, 1])
        _draw_landmark_estimates(zoom, result, lm_names, colours)
        zoom.plot(*lm[lid], ms=14, zorder=4, **star)
        half = _zoom_half_width(result, lm_names, lid, lm[lid])
        zoom.set_xlim(lm[lid][0] - half, lm[lid][0] + half)
        zoom.set_ylim(lm[lid][1] - half, lm[lid][1] + half)
        zoom.set_aspect("equal")
        zoom.grid(True, lw=0.3, alpha=0.5)
        zoom.tick_params(labelsize=8)
        zoom.set_title(f"zoom: landmark {lid} (largest 2σ)", fontsize=9)
        ax.add_patch(Rectangle((lm[lid][0] - half, lm[lid][1] - half), 2 * half, 2 * half,
                               fill=False, ec="0.3", lw=0.8, zorder=8))
        ax.annotate("zoom", (lm[lid][0] + half, lm[lid][1] + half), fontsize=8,
                    color="0.3", xytext=(2, 2), textcoords="offset points")
    save(fig, path)


_XY_GRID = ErrorGrid(axes=("x", "y"), width=10.5, top=1.2, ylabel="{name}: {axis} error (m)",
                    legend=("error", "sigma", "envelope", "paper", "reference"),
                    title="vehicle position error", sharey=True)


def plot_errors_xy(result: CampaignResult, path: Path) -> None:
    """``errors_xy.png``: one row per filter, x error (left) and y error (right) vs time.

    Each panel: run 0's error, its ±2σ band (from the pose covariance), the Monte Carlo
    envelope (min / max over the runs that did not diverge), the smoother's run-0 error
    for reference, and dashed lines at the paper's range where the paper quotes one.
    """
    first = run0(result)
    ref = first.scores.get(REFERENCE)

    def panel(name: str, col: int) -> ErrorPanel:
        track, sc0 = first.tracks.get(name), first.scores.get(name)
        env = envelope(_good_scores(result, name), lambda s: s.err[:, col])
        shown = None
        if sc0 is not None and not sc0.diverged and track is not None:
            with np.errstate(invalid="ignore"):
                shown = (sc0.err[:, col], np.sqrt(track.pose_cov[:, col, col]))
        note = "diverged on every run" if env is None else "diverged on run 0"
        return ErrorPanel(env, shown, note if col == 0 else "",
                          None if ref is None else ref.err[:, col],
                          paper_range(result.summary, name, _XY_GRID.axes[col]))

    error_grid(result, path, _XY_GRID, panel, estimator_colours(result))


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png``: run-averaged NEES / 3 vs time per filter, with the 95 % band."""
    first = run0(result)
    colours = estimator_colours(result)
    t = first.times
    fig, ax = plt.subplots(figsize=(10, 4.6), layout="constrained")
    bands: dict[tuple[float, float], list[str]] = {}
    for name in filter_names(result):
        scores = _good_scores(result, name)
        if not scores:
            continue
        mean = run_average([s.nees for s in scores], 3.0)
        entry = result.summary["filters"].get(name, {})
        anees = entry.get("anees")
        label = name if anees is None else f"{name} (ANEES {anees:.2f})"
        ax.plot(t, mean, color=colours[name], lw=0.8, alpha=0.85, label=label)
        band = entry.get("anees_bounds_95")
        if band:
            bands.setdefault((float(band[0]), float(band[1])), []).append(name)
    for (lo, hi), who in bands.items():
        colour = "black" if len(bands) == 1 else colours[who[0]]
        runs = len(_good_scores(result, who[0]))
        label = f"95 % band ({runs} runs)" + ("" if len(bands) == 1 else f": {', '.join(who)}")
        ax.axhline(lo, color=colour, ls="--", lw=1.2, label=label)
        ax.axhline(hi, color=colour, ls="--", lw=1.2)
    ax.axhline(1.0, color="0.5", lw=0.6)
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.tick_params(axis="y", which="both", labelsize=8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("NEES / 3 (run average)")
    ax.set_title(titled(result, "pose consistency (a consistent filter stays near 1, inside "
                               "the band)"))
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", fontsize=8,
               ncols=max(len(handles), 1), frameon=False)
    save(fig, path)


def figure_writers() -> dict[str, Callable[[CampaignResult, Path], None]]:
    """File name -> function drawing it (looked up at call time)."""
    return {"map.png": plot_map, "errors_xy.png": plot_errors_xy, "nees.png": plot_nees}


# --------------------------------------------------------------------------- TUM

def tum_text(times: Array, poses: Array) -> str:
    """TUM trajectory lines ``t x y z qx qy qz qw`` for planar poses ``[x, y, φ]``.

    z = 0 and the quaternion is the yaw rotation by φ; rows with a non-finite pose
    (a diverged filter) are left out so that tools such as ``evo`` can read the file.
    """
    ok = np.all(np.isfinite(poses), axis=1) & np.isfinite(times)
    t, p = times[ok], poses[ok]
    half = 0.5 * p[:, 2]
    return tum_lines(np.column_stack([t, p[:, 0], p[:, 1], np.zeros(len(t)), np.zeros(len(t)),
                                      np.zeros(len(t)), np.sin(half), np.cos(half)]))


def write_tum_files(result: CampaignResult, out_dir: Path) -> list[str]:
    """``truth.tum`` and ``<name>.tum`` for every estimator tracked on run 0."""
    first = result.outcomes[0]
    if first.truth is None or first.times is None:
        return []
    items = [("truth", first.truth), *((n, tr.poses) for n, tr in first.tracks.items())]
    return write_tum(out_dir, ((n, tum_text(first.times, p)) for n, p in items))


REPORT = KindReport("planar SLAM campaign", planar_sections, planar_figures,
                    RESULTS.plain, write_tum_files)
"""The planar SLAM kind's report."""
