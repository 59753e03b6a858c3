"""Scores of a planar SLAM run: pose errors, per-run reduction and the Monte Carlo
summary of one estimator (NEES/ANEES from :mod:`slam.scoring`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from estimators import wrap_angle
from slam.results import Array, RunScores
from slam.scoring import (
    anees_entries,
    nees_series,
    nis_and_timing,
    pad_stack,
    scored_runs,
    track_frame,
)


def pose_errors(poses: Array, truth: Array) -> Array:
    """``poses - truth`` with the heading difference wrapped; shape (K + 1, 3)."""
    err = poses - truth
    err[:, 2] = wrap_angle(err[:, 2])
    return err


def reduce_run(name: str, poses: Array, pose_cov: Array, truth: Array, landmark_ids: Array,
               landmarks: Array, true_landmarks: Array | None, nis: Array, nis_dof: Array,
               time_s: float, diverged: bool = False, failure: str | None = None, *,
               nis_epoch: Array | None = None, map_series: Any = None) -> RunScores:
    """Reduce one estimator's output on one run to its :class:`RunScores`
    (``nis_epoch`` and ``map_series`` as :class:`~slam.mapping.problem.SlamResult`'s)."""
    err = pose_errors(poses, truth)
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.diagonal(pose_cov, axis1=1, axis2=2))
    err_track, sig_track = (a.astype(np.float32) for a in
                            track_frame(err[:, :2], pose_cov[:, :2, :2], truth[:, 2]))
    if true_landmarks is not None and len(landmark_ids):
        known = landmark_ids >= 0
        lm_err = np.linalg.norm(landmarks[known] - true_landmarks[landmark_ids[known]], axis=1)
    else:
        lm_err = np.zeros(0)
    return RunScores(name, err, sigma, nees_series(err, pose_cov), lm_err,
                     nis=np.asarray(nis, float), nis_dof=np.asarray(nis_dof, int),
                     time_s=float(time_s), steps=poses.shape[0] - 1, diverged=diverged,
                     failure=failure, err_track=err_track, sig_track=sig_track,
                     nis_epoch=None if nis_epoch is None else np.asarray(nis_epoch, int),
                     map_series=map_series)


def summarize(scores: list[RunScores], *, with_heading: bool = True) -> dict:
    """Monte Carlo summary of one estimator (a ``summary.json`` filter entry).

    Diverged runs are counted and left out of every error statistic.
    """
    good, out = scored_runs(scores)
    if not good:
        return out
    err = pad_stack([s.err for s in good])  # (R, E, 3), NaN after a shorter run's end
    pos2 = err[..., 0] ** 2 + err[..., 1] ** 2
    out["pos_rmse_m"] = float(np.sqrt(np.nanmean(pos2)))
    out["pos_err_range_m"] = {
        "x": [float(np.nanmin(err[..., 0])), float(np.nanmax(err[..., 0]))],
        "y": [float(np.nanmin(err[..., 1])), float(np.nanmax(err[..., 1]))],
    }
    if with_heading:
        out["heading_rmse_deg"] = float(np.degrees(np.sqrt(np.nanmean(err[..., 2] ** 2))))
    lm = np.concatenate([s.lm_err for s in good])
    if lm.size:
        out["landmark_rmse_m"] = float(np.sqrt(np.mean(lm**2)))
    out.update(anees_entries(pad_stack([s.nees for s in good]), 3))  # (R, E)
    out.update(nis_and_timing(good))
    return out


