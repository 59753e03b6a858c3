"""The planar report's map figure (``map.png``): the world, run 0's paths and final
landmark estimates with their 2σ ellipses, and a zoom on the least certain landmark."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from slam.render import plotting
from slam.render.figures import default_colours
from slam.results import ODOMETRY, REFERENCE, Array, CampaignResult

_TRUTH_STYLE = {"color": "black", "lw": 1.6}
_BASELINE_STYLE = {
    ODOMETRY: {"color": plotting.BASELINE_COLOUR, "lw": 1.0, "ls": ":"},
    REFERENCE: {"color": plotting.REFERENCE_COLOUR, "lw": 1.2, "ls": "--"},
}


def _landmark_estimators(result: CampaignResult) -> list[str]:
    """Run 0's estimators that estimate landmarks: filters, then the smoother."""
    first = result.outcomes[0]
    return [n for n in [*plotting.filter_names(result), REFERENCE]
            if n in first.tracks and len(first.tracks[n].landmarks)]


def _draw_landmark_estimates(ax: Axes, result: CampaignResult, names: Sequence[str],
                             colours: dict[str, str]) -> None:
    """Each estimator's final landmark means (+) and their 2σ ellipses."""
    first = result.outcomes[0]
    for name in names:
        track = first.tracks[name]
        for mean, cov in zip(track.landmarks, track.landmark_cov):
            ell = plotting.covariance_ellipse(mean, cov, fc="none", ec=colours[name], lw=1.0,
                                              zorder=5)
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
    first, world = plotting.run0(result), result.world
    colours = default_colours(result)
    fig = plotting.plt.figure(figsize=(11.0, 7.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(3.0, 1.2))
    plotting.inch_layout(fig, 2, 2, grid=grid, left=0.75, top=0.3, bottom=0.5, wgap=0.85,
                         hgap=0.45)
    ax = fig.add_subplot(grid[:, 0])
    xmin, xmax, ymin, ymax = world.map.bounds_m
    ax.add_patch(Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False,
                           ec="0.75", lw=0.8))
    wp = world.map.waypoints
    ax.plot(wp[:, 0], wp[:, 1], "s", ms=5, mfc="none", mec="0.45", label="waypoints")
    truth = first.truth
    ax.plot(truth[:, 0], truth[:, 1], label="true path", zorder=2, **_TRUTH_STYLE)
    ax.plot(truth[0, 0], truth[0, 1], "o", color="black", ms=7, label="start", zorder=6)
    for name in [*plotting.filter_names(result), ODOMETRY, REFERENCE]:
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
    ax.set_title(plotting.titled(result, "run 0"))
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
        zoom.set_xlabel("x (m)", fontsize=9)
        zoom.set_ylabel("y (m)", fontsize=9)
        zoom.set_title(f"zoom: landmark {lid} (largest 2σ)", fontsize=9)
        ax.add_patch(Rectangle((lm[lid][0] - half, lm[lid][1] - half), 2 * half, 2 * half,
                               fill=False, ec="0.3", lw=0.8, zorder=8))
        ax.annotate("zoom", (lm[lid][0] + half, lm[lid][1] + half), fontsize=8,
                    color="0.3", xytext=(2, 2), textcoords="offset points")
    plotting.save(fig, path)
