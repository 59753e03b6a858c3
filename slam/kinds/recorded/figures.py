"""Figures of a recorded-log run (``slam run --log``), drawn from the run's tracks
(:func:`~slam.kinds.recorded.tracks.log_tracks`).  A log has no ground truth: the
filters are compared with the GTSAM smoother on the same measurements, and the x axis is
the pose index along the odometry chain (the log carries no time stamps).

    trajectories.png  the smoother's, the filters' and the odometry's paths and final maps
    aligned_map.png   each filter's map against the smoother's, as estimated and after
                      the best rigid rotation + translation (what is left is distortion)
    pose_diff.png     position and heading difference to the smoother vs pose index,
                      with the filter's own ±2σ
    map_state.png     landmarks in the state, the map covariance's trace and the NIS / dof
                      per epoch in its 95 % band
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
from matplotlib.lines import Line2D

from estimators import wrap_angle
from slam.kinds.recorded.scoring import rigid_fit
from slam.render.figures import (
    COINCIDE,
    NOTE_CHARS,
    PANEL_WIDTH,
    Figure,
    FigureSpec,
    default_colours,
    figure_table,
)
from slam.render.plotting import (
    BASELINE_COLOUR,
    REFERENCE_COLOUR,
    filter_names,
    inch_layout,
    legend_margin,
    plt,
    readable_log_axis,
    save,
    titled,
)
from slam.render.series import chi2_band, coincidence_note, fraction_inside
from slam.results import ODOMETRY, REFERENCE, CampaignResult

DEG = 180.0 / math.pi
POSE_INDEX = "pose index along the odometry chain"


def _tracks(result: CampaignResult) -> dict:
    return result.outcomes[0].tracks if result.outcomes else {}


def _filters(result: CampaignResult) -> list[str]:
    tracks = _tracks(result)
    return [n for n in filter_names(result) if n in tracks]


def _common(track, ref) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the landmarks both maps hold, into ``track`` and into ``ref``."""
    pos = {int(j): i for i, j in enumerate(ref.landmark_ids)}
    pairs = [(i, pos[int(j)]) for i, j in enumerate(track.landmark_ids) if int(j) in pos]
    return (np.array(pairs, dtype=int).T if pairs else (np.zeros(0, int), np.zeros(0, int)))


def plot_trajectories(result: CampaignResult, path) -> None:
    """The smoother's (dashed), filters' and odometry's (dotted) paths and final maps."""
    tracks, col = _tracks(result), default_colours(result)
    fig, ax = plt.subplots(figsize=(PANEL_WIDTH, 8.0))
    inch_layout(fig, 1, 1, left=0.75, top=0.3, bottom=0.5)
    odo = tracks.get(ODOMETRY)
    if odo is not None:
        ax.plot(odo.poses[:, 0], odo.poses[:, 1], color=BASELINE_COLOUR, lw=0.8, ls=":",
                label="odometry (dead reckoning; may leave the frame)")
    for name in _filters(result):
        tr = tracks[name]
        ax.plot(tr.poses[:, 0], tr.poses[:, 1], color=col[name], lw=0.9, label=name)
        ax.plot(tr.landmarks[:, 0], tr.landmarks[:, 1], "+", color=col[name], ms=6)
    ref = tracks.get(REFERENCE)
    if ref is not None:
        ax.plot(ref.poses[:, 0], ref.poses[:, 1], color=REFERENCE_COLOUR, lw=1.1, ls="--",
                label="gtsam smoother")
        ax.plot(ref.landmarks[:, 0], ref.landmarks[:, 1], "o", mfc="none",
                color=REFERENCE_COLOUR, ms=6, label="smoother's landmarks")
    ax.plot([], [], "+", color="0.3", label="filters' landmarks")
    _frame(ax, [tracks[n] for n in tracks if n != ODOMETRY])
    ax.set_aspect("equal", adjustable="box")  # the frame is fixed: the box gives way
    ax.set_xlabel("x (m, frame of the first pose)")
    ax.set_ylabel("y (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(fontsize=9, loc="best")
    ax.set_title(titled(result, "paths and final maps"), fontsize=11)
    save(fig, path)


def _frame(ax, tracks: list) -> None:
    """Axis limits holding the smoother's and the filters' paths and maps (10 % margin):
    the odometry may leave the frame."""
    pts = [p for tr in tracks for p in (tr.poses[:, :2], tr.landmarks)]
    pts = np.concatenate(pts) if pts else np.zeros((0, 2))
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts):
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.1 * max(float(np.max(hi - lo)), 1.0)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)


def plot_aligned_map(result: CampaignResult, path) -> None:
    """Each filter's final map against the smoother's, as estimated (left) and after the
    best rigid rotation + translation (right); grey lines join matching landmarks."""
    tracks, col = _tracks(result), default_colours(result)
    ref = tracks.get(REFERENCE)
    fig, axes = plt.subplots(1, 2, figsize=(PANEL_WIDTH, 6.0))
    inch_layout(fig, 1, 2, left=0.75, top=0.6, bottom=0.55, wgap=0.85)
    for name in _filters(result) if ref is not None else []:
        a, b = _common(tracks[name], ref)
        A, B = tracks[name].landmarks[a], ref.landmarks[b]
        if len(a) < 2 or not np.all(np.isfinite(A)):
            continue
        rot, fitted = rigid_fit(A, B)
        labels = (f"{name}: median {np.median(np.linalg.norm(A - B, axis=1)):.2f} m",
                  f"{name}: rotated {rot:+.2f}°, median "
                  f"{np.median(np.linalg.norm(fitted - B, axis=1)):.2f} m")
        for ax, pts, label in zip(axes, (A, fitted), labels):
            ax.plot(np.c_[pts[:, 0], B[:, 0]].T, np.c_[pts[:, 1], B[:, 1]].T, color="0.7",
                    lw=0.6)
            ax.plot(pts[:, 0], pts[:, 1], "+", color=col[name], ms=7, label=label)
    for ax, what in zip(axes, ("as estimated", "after the best rigid fit to the smoother's")):
        if ref is not None:
            ax.plot(ref.landmarks[:, 0], ref.landmarks[:, 1], "o", mfc="none",
                    color=REFERENCE_COLOUR, ms=6, label="smoother")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(what, fontsize=10)
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, loc="best")
    fig.suptitle(titled(result, "filter maps vs the smoother's (distances to its landmarks)"),
                 fontsize=11)
    save(fig, path)


def plot_pose_diff(result: CampaignResult, path) -> None:
    """Position and heading difference of each filter to the smoother vs pose index, with
    the filter's own ±2σ (the smoother's own uncertainty is not drawn)."""
    tracks, col = _tracks(result), default_colours(result)
    ref = tracks.get(REFERENCE)
    fig, (ap, ah) = plt.subplots(2, 1, figsize=(PANEL_WIDTH, 6.4), sharex=True)
    inch_layout(fig, 2, 1, left=0.75, top=0.35, bottom=0.55, hgap=0.15)
    for name in _filters(result) if ref is not None else []:
        tr = tracks[name]
        k = tr.steps.astype(int)
        d = tr.poses - ref.poses[k]
        with np.errstate(invalid="ignore"):
            sd = np.sqrt(np.diagonal(tr.pose_cov, axis1=1, axis2=2))
        ap.plot(k, np.hypot(d[:, 0], d[:, 1]), color=col[name], lw=0.9, label=name)
        ap.plot(k, 2 * np.hypot(sd[:, 0], sd[:, 1]), color=col[name], lw=0.7, ls="--")
        ah.plot(k, wrap_angle(d[:, 2]) * DEG, color=col[name], lw=0.9)
        for sign in (-1, 1):
            ah.plot(k, sign * 2 * sd[:, 2] * DEG, color=col[name], lw=0.7, ls="--")
    ap.set_ylabel("|position difference| (m)")
    ah.set_ylabel("heading difference (deg)")
    ah.set_xlabel(POSE_INDEX)
    for ax in (ap, ah):
        ax.grid(True, lw=0.3, alpha=0.5)
    ah.axhline(0.0, color="0.5", lw=0.5)
    handles, _ = ap.get_legend_handles_labels()
    handles.append(Line2D([], [], color="0.3", lw=0.7, ls="--", label="filter's own 2σ"))
    ap.legend(handles=handles, fontsize=9, loc="upper left")
    fig.suptitle(titled(result, "each filter minus the smoother"), fontsize=11)
    save(fig, path)


def map_state_curves(result: CampaignResult) -> dict[str, dict[str, np.ndarray | None]]:
    """Each filter's map-state curves, panel -> filter -> curve (for the coincidence
    note): landmarks in the state and the map covariance trace per epoch."""
    tracks = _tracks(result)
    out: dict[str, dict[str, np.ndarray | None]] = {k: {} for k in MAP_STATE_UNITS}
    for name in _filters(result):
        m = tracks[name].map_series
        if m is not None:
            out["landmarks in the state"][name] = np.asarray(m.n, dtype=float)
            out["map covariance trace"][name] = np.asarray(m.trace, dtype=float)
    return out


MAP_STATE_UNITS = {"landmarks in the state": "", "map covariance trace": "m²"}


def plot_map_state(result: CampaignResult, path) -> None:
    """Landmarks in the state, the trace of the map covariance and the NIS / dof over
    windows of :data:`WINDOW` updates against its 95 % band; under the legend, which
    filters' map curves coincide (:func:`slam.render.series.coincidence_note`)."""
    tracks, col = _tracks(result), default_colours(result)
    fig, axes = plt.subplots(3, 1, figsize=(PANEL_WIDTH, 8.4), sharex=True)
    lines = textwrap.wrap(coincidence_note(map_state_curves(result), MAP_STATE_UNITS,
                                           "map curves"), int(NOTE_CHARS * PANEL_WIDTH))
    legend = legend_margin(len(_filters(result)) + 1, 2, base=0.65, row=0.21)
    if lines:
        fig.text(0.5, 0.08 / 8.4, "\n".join(lines), ha="center", va="bottom", fontsize=8)
    # the NIS legend hangs below the last axes
    inch_layout(fig, 3, 1, left=0.75, top=0.35, hgap=0.15, bottom=legend + 0.15 * len(lines))
    for name in _filters(result):
        tr = tracks[name]
        k = tr.steps.astype(int)
        if tr.map_series is not None:
            axes[0].plot(k, tr.map_series.n, color=col[name], lw=1.0, label=name)
            trace = np.asarray(tr.map_series.trace, dtype=float)
            axes[1].plot(k, np.where(trace > 0, trace, np.nan), color=col[name], lw=1.0)
        if tr.nis is not None and len(tr.nis):
            ke = k[np.asarray(tr.nis_epoch, dtype=int)]
            value, lo, hi = windowed_nis(tr.nis, tr.nis_dof, min(WINDOW, len(tr.nis)))
            inside = fraction_inside(value, lo, hi)
            mean = float(np.sum(tr.nis) / np.sum(tr.nis_dof))
            axes[2].plot(ke, value, color=col[name], lw=0.9,
                         label=f"{name}: NIS/dof {mean:.2f} overall, {100 * (inside or 0):.0f}"
                               " % of windows in band")
            if name == _filters(result)[0]:
                axes[2].fill_between(ke, lo, hi, color="0.5", alpha=0.25, lw=0,
                                     label="95 % band")
    axes[0].set_ylabel("landmarks in the state")
    axes[1].set_ylabel("trace of map covariance (m²)")
    axes[2].set_ylabel(f"NIS / dof ({WINDOW} updates)")
    for ax in axes[1:]:
        if ax.lines:
            ax.set_yscale("log")
            readable_log_axis(ax)
    axes[2].set_xlabel(POSE_INDEX)
    for ax in axes:
        ax.grid(True, lw=0.3, alpha=0.5)
    if axes[0].lines:
        axes[0].legend(fontsize=9, loc="upper left")
    if axes[2].lines:
        axes[2].legend(fontsize=9, loc="upper left", bbox_to_anchor=(0.0, -0.18), ncols=2)
    fig.suptitle(titled(result, "the filters' map and innovations over the log"), fontsize=11)
    save(fig, path)


WINDOW = 25
"""Updates per window of the NIS panel."""


def windowed_nis(nis: np.ndarray, dof: np.ndarray, window: int = WINDOW
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Σ NIS / Σ dof over the ``window`` updates ending at each update (fewer at the
    start) and its two-sided 95 % χ² band."""
    c_nis = np.concatenate([[0.0], np.cumsum(nis)])
    c_dof = np.concatenate([[0.0], np.cumsum(np.asarray(dof, dtype=float))])
    end = np.arange(1, len(nis) + 1)
    start = np.maximum(end - window, 0)
    d = c_dof[end] - c_dof[start]
    lo, hi = chi2_band(d)
    return (c_nis[end] - c_nis[start]) / d, lo, hi


def figure_specs() -> list[FigureSpec]:
    """The recorded-log report's figures."""
    return [
        FigureSpec("trajectories.png", "Paths and final maps: the GTSAM smoother (dashed, "
                   "landmarks ○), each filter (landmarks +) and the compounded odometry "
                   "(dotted), in the frame of the first pose.", plot_trajectories),
        FigureSpec("aligned_map.png", "Each filter's final landmarks against the smoother's "
                   "(○; grey lines join matching landmarks): as estimated (left) and after "
                   "the best rigid rotation + translation (right). A map that only rotates "
                   "as a whole is a heading error; what is left after the fit is "
                   "distortion.", plot_aligned_map),
        FigureSpec("pose_diff.png", "Each filter minus the smoother vs the pose index "
                   "(the log has no time stamps): horizontal position difference with the "
                   "filter's own 2σ (dashed), heading difference with its ±2σ.",
                   plot_pose_diff),
        FigureSpec("map_state.png", "Per filter epoch: landmarks in the state, trace of the "
                   "map covariance, and the NIS / dof over windows of 25 batch updates against "
                   "its 95 % band (grey): the filters' only consistency check without truth. "
                   + COINCIDE.replace("above the legend", "at the bottom"), plot_map_state),
    ]


def figures() -> dict[str, tuple[Figure, str]]:
    """The report's figures, file name -> (drawing function, caption); the report names
    this module lazily, so a run without figures never imports matplotlib."""
    return figure_table(figure_specs())
