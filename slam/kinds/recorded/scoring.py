"""Scoring a filter on a recorded log against the smoother, and the run's summary."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from estimators import wrap_angle
from estimators.linalg import Array
from slam.failures import run_reference
from slam.kinds.planar.world import ONLINE
from slam.kinds.recorded.log import DEFAULT_FILTERS, DEFAULT_MAX_EPOCH_STEPS, OdometryLog
from slam.kinds.recorded.models import dead_reckoning_poses, recorded_epochs, run_recorded
from slam.kinds.recorded.online import online_recorded
from slam.kinds.recorded.reference import RecordedReference, smooth_recorded
from slam.mapping.problem import SlamResult

# --------------------------------------------------------------------------- scoring


def heading_sigma_deg(cov: Array) -> float | None:
    """σ of the heading (deg) of a pose covariance ``[x, y, θ]`` (None if not finite)."""
    v = float(cov[2, 2])
    return float(np.degrees(np.sqrt(v))) if np.isfinite(v) and v >= 0.0 else None


def score_filter(result: SlamResult, ref: RecordedReference | None,
                 sigma: bool = False) -> dict[str, Any]:
    """One filter against the smoother (keys that do not apply are left out; only the
    filter's own keys when the smoother failed, ``ref = None``); ``time_per_epoch_ms``
    is ``time_s`` over the epochs after the first; with ``sigma`` also the filter's own
    heading σ at its last epoch (``final_heading_sigma_deg``, the online rows' yardstick:
    :func:`run_log`)."""
    out: dict[str, Any] = {"time_s": result.time_s, "diverged": result.diverged,
                           "landmarks_mapped": int(len(result.landmark_ids))}
    if len(result.steps) > 1:
        out["time_per_epoch_ms"] = 1e3 * result.time_s / (len(result.steps) - 1)
    if result.failure:
        out["failure"] = result.failure
    if sigma and len(result.pose_cov):
        h = heading_sigma_deg(result.pose_cov[-1])
        if h is not None:
            out["final_heading_sigma_deg"] = h
    if ref is None:
        return out
    pos = {int(j): i for i, j in enumerate(ref.landmark_ids)}
    common = [(i, pos[int(j)]) for i, j in enumerate(result.landmark_ids) if int(j) in pos]
    if common:
        a, b = np.array(common).T
        A, B = result.landmarks[a], ref.landmarks[b]
        d = np.linalg.norm(A - B, axis=1)
        if np.all(np.isfinite(d)):
            out["landmark_dist_to_ref_median_m"] = float(np.median(d))
            out["landmark_dist_to_ref_max_m"] = float(np.max(d))
            if len(d) >= 2:
                rot, d_aligned = _rigid_fit(A, B)
                out["map_rotation_to_ref_deg"] = rot
                out["landmark_dist_to_ref_aligned_median_m"] = float(np.median(d_aligned))
                out["landmark_dist_to_ref_aligned_max_m"] = float(np.max(d_aligned))
    last = result.poses[-1]
    if np.all(np.isfinite(last)):
        end = ref.poses[int(result.steps[-1])]
        out["final_pose_dist_to_ref_m"] = float(np.hypot(*(last[:2] - end[:2])))
        out["final_heading_diff_to_ref_deg"] = float(np.degrees(abs(wrap_angle(last[2]
                                                                               - end[2]))))
    ok = np.all(np.isfinite(result.poses), axis=1)
    if ok.any():
        e = result.poses[ok, :2] - ref.poses[result.steps[ok], :2]
        out["pose_rmse_to_ref_m"] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
        dh = np.degrees(wrap_angle(result.poses[ok, 2] - ref.poses[result.steps[ok], 2]))
        out["heading_rmse_to_ref_deg"] = float(np.sqrt(np.mean(dh**2)))
    if result.time_s > 0:
        out["isam2_time_over_filter_time"] = ref.time_isam2_s / result.time_s
    return out


def to_online(result: SlamResult, row: SlamResult) -> dict[str, float]:
    """A filter's position and heading RMS difference (m, deg) to the online row over the
    epochs both estimated (the same epochs: :func:`run_log`); empty if there are none."""
    if not np.array_equal(result.steps, row.steps):
        return {}
    ok = np.all(np.isfinite(result.poses), axis=1) & np.all(np.isfinite(row.poses), axis=1)
    if not ok.any():
        return {}
    e = result.poses[ok, :2] - row.poses[ok, :2]
    dh = np.degrees(wrap_angle(result.poses[ok, 2] - row.poses[ok, 2]))
    return {"pose_rmse_to_online_m": float(np.sqrt(np.mean(np.sum(e**2, axis=1)))),
            "heading_rmse_to_online_deg": float(np.sqrt(np.mean(dh**2)))}


def _rigid_fit(A: Array, B: Array) -> tuple[float, Array]:
    """Best rotation + translation of points ``A`` onto ``B`` (least squares): the
    rotation (deg) and the distances left after it.  Separates a map that is rotated as
    a whole (a filter's heading error) from one that is distorted."""
    deg, fitted = rigid_fit(A, B)
    return deg, np.linalg.norm(fitted - B, axis=1)


def rigid_fit(A: Array, B: Array) -> tuple[float, Array]:
    """The rotation (deg) of the best rigid fit of points ``A`` onto ``B`` and ``A`` so
    moved."""
    ca, cb = A.mean(axis=0), B.mean(axis=0)
    H = (A - ca).T @ (B - cb)
    ang = math.atan2(H[0, 1] - H[1, 0], H[0, 0] + H[1, 1])
    c, s = math.cos(ang), math.sin(ang)
    R = np.array([[c, -s], [s, c]])
    return math.degrees(ang), (A - ca) @ R.T + cb


def run_log(log: OdometryLog, filters: tuple[str, ...] | list[str] = DEFAULT_FILTERS, *,
            mode: str = "local", max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS,
            progress=None, keep: dict[str, Any] | None = None,
            settings: dict[str, dict[str, Any]] | None = None,
            online: bool = False) -> dict[str, Any]:
    """Run the filters and the smoother on ``log``; the ``summary.json`` dict.  With
    ``keep`` (a dict) the raw outputs are left in it for the report: ``results`` (filter
    name -> :class:`~slam.mapping.problem.SlamResult`) and ``reference`` (the smoother's
    :class:`~slam.kinds.recorded.reference.RecordedReference` or None).  ``settings``
    maps a filter name to its settings (:func:`estimators.make_filter`'s keywords).

    ``online``: also the online row ``isam2`` (:mod:`slam.kinds.recorded.online`, the
    smoother from the same pass) in group ``online``, scored like a filter, every row's
    final heading σ (the smoother's: its ``gtsam.Marginals`` at the last pose) and each
    filter's difference to the online row (:func:`to_online`)."""
    results = {}
    for name in filters:
        results[name] = run_recorded(log, name, mode=mode, max_epoch_steps=max_epoch_steps,
                                     filter_params=(settings or {}).get(name))
        if progress:
            progress(1)
    row: SlamResult | None = None
    if online:
        both, failure = run_reference(online_recorded, log,
                                      recorded_epochs(log, max_epoch_steps),
                                      final_marginal=True)
        row, ref = both if both is not None else (None, None)
    else:
        ref, failure = run_reference(smooth_recorded, log)
    if keep is not None:
        keep.update(results=results, reference=ref)
        if row is not None:
            keep["online"] = {ONLINE: row}
    if progress:
        progress(1)
    head = {
        "log": Path(log.source).name,
        "source": log.source,
        "mode": mode,
        "poses": log.n_poses,
        "landmarks": int(len(log.landmark_ids)),
        "observations": int(len(log.obs_id)),
        "filters": {n: score_filter(r, ref, online) for n, r in results.items()},
    }
    if online:
        head["online"] = {ONLINE: score_filter(row, ref, True) if row is not None else
                          {"diverged": True, "failure": failure}}
        if row is not None:
            for n, r in results.items():
                head["filters"][n].update(to_online(r, row))
    if ref is None:  # the smoother failed: the filters are unscored, nothing is lost
        return {**head, "baselines": {"odometry": {}},
                "reference": {"gtsam": {"diverged": True, "failure": failure}}}
    odo = dead_reckoning_poses(log)
    return {
        **head,
        "baselines": {"odometry": {
            "final_pose_dist_to_ref_m": float(np.hypot(*(odo[-1, :2] - ref.poses[-1, :2]))),
            "pose_rmse_to_ref_m": float(np.sqrt(np.mean(np.sum((odo[:, :2]
                                                                - ref.poses[:, :2])**2, 1)))),
        }},
        "reference": {"gtsam": {
            "method": "iSAM2 pose by pose, then Levenberg-Marquardt",
            "objective_isam2": ref.objective_isam2,
            "objective": ref.objective,
            "time_isam2_s": ref.time_isam2_s,
            "time_lm_s": ref.time_lm_s,
            "time_s": ref.time_s,
            **({"final_heading_sigma_deg": heading_sigma_deg(ref.final_pose_cov)}
               if ref.final_pose_cov is not None else {}),
        }},
    }


