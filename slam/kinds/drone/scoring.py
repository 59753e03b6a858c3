"""Scores of a drone run at the sensor epochs: position, velocity and attitude errors,
position and pose NEES, landmark errors; the Monte Carlo summary of one estimator."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import wrap_angle
from estimators.linalg import Array
from nav.euler import euler_error_jacobian, q_to_euler_zyx
from slam.kinds.drone.filtering import DroneEstimate
from slam.kinds.drone.models import QUAT, VEH_DIM
from slam.kinds.drone.simulate import DroneLog
from slam.results import SlamRunScores
from slam.scoring import anees_entries, nees_series, nis_and_timing, scored_runs, track_frame

AXES = ("x", "y", "z")
ATT_AXES = ("roll", "pitch", "yaw")


# --------------------------------------------------------------------------- scoring

@dataclass(frozen=True)
class DroneScores(SlamRunScores):
    """One estimator on one run, reduced (at the sensor epochs; and the
    :class:`~slam.results.SlamRunScores` fields: nis, nis_dof, time_s of ``steps`` epochs).

    err_pos (E, 3) estimate minus truth (m), sig_pos (E, 3) own σ; err_vel (E, 3);
    err_att (E, 3) roll/pitch/yaw estimate minus truth (rad, wrapped), sig_att (E, 3);
    nees_pos (E,) 3-dof, nees_pose (E,) 6-dof (NaN at epoch 0, the prior); lm_ids (L,),
    lm_err (L,) final 3-D landmark errors (m).

    For the figures (single precision; NaN where the estimator gives none): sig_vel
    (E, 3) m/s; err_bias, sig_bias (E, 6) ``[b_g (rad/s), b_a (m/s²)]`` estimate minus
    truth and own σ; nees_att (E,) 3-dof body-frame attitude NEES; err_track, sig_track
    horizontal, in the frame of the true horizontal velocity.
    """

    name: str
    err_pos: Array
    sig_pos: Array
    err_vel: Array
    err_att: Array
    sig_att: Array
    nees_pos: Array
    nees_pose: Array
    lm_ids: Array
    lm_err: Array
    sig_vel: Array | None = None
    err_bias: Array | None = None
    sig_bias: Array | None = None
    nees_att: Array | None = None


@dataclass(frozen=True)
class DroneTrack:
    """Run 0's full output of one estimator (for plots and trajectory files)."""

    name: str
    p: Array
    q: Array
    pose_cov: Array
    bias: Array
    landmark_ids: Array
    landmarks: Array
    landmark_cov: Array


def score(est: DroneEstimate, log: DroneLog) -> DroneScores:
    """Reduce an estimate to :class:`DroneScores` against the log's truth."""
    tp, tv, tq = log.truth[:, 0:3], log.truth[:, 3:6], log.truth[:, 6:10]
    E = log.n_epochs
    ok = np.all(np.isfinite(est.q), axis=1)
    err_pos = est.p - tp
    err_vel = est.v - tv
    err_att = np.full((E, 3), np.nan)
    err_rot = np.full((E, 3), np.nan)
    sig_att = np.full((E, 3), np.nan)
    C = est.pose_cov
    if ok.any():
        err_att[ok] = wrap_angle(q_to_euler_zyx(est.q[ok]) - q_to_euler_zyx(tq[ok]))
        err_rot[ok] = QUAT.local(est.q[ok], tq[ok])
        J = euler_error_jacobian(est.q[ok], q_to_euler_zyx)
        with np.errstate(invalid="ignore"):
            Ce = J @ C[ok, 3:, 3:] @ np.swapaxes(J, -1, -2)
            sig_att[ok] = np.sqrt(np.clip(np.diagonal(Ce, axis1=1, axis2=2), 0.0, None))
    with np.errstate(invalid="ignore"):
        sig_pos = np.sqrt(np.clip(np.diagonal(C[:, :3, :3], axis1=1, axis2=2), 0.0, None))
    nees_pos = nees_series(-err_pos, C[:, :3, :3])
    nees_pose = nees_series(np.hstack([-err_pos, err_rot]), C)
    nees_pos[0] = nees_pose[0] = np.nan  # epoch 0 is the prior, not an estimate
    known = est.landmark_ids >= 0
    lm_err = np.linalg.norm(est.landmarks[known] - log.landmarks[est.landmark_ids[known]],
                            axis=1) if known.any() else np.zeros(0)
    return DroneScores(est.name, err_pos, sig_pos, err_vel, err_att, sig_att, nees_pos,
                       nees_pose, est.landmark_ids[known], lm_err, nis=est.nis,
                       nis_dof=est.nis_dof, time_s=est.time_s, steps=est.steps,
                       diverged=est.diverged, failure=est.failure, extra_time_s=est.extra_time_s,
                       **_figure_series(est, log, err_pos, err_rot))


def _figure_series(est: DroneEstimate, log: DroneLog, err_pos: Array, err_rot: Array
                   ) -> dict[str, Any]:
    """The per-epoch arrays only the figures use (single precision)."""
    E, C = log.n_epochs, est.pose_cov
    var = np.full((E, VEH_DIM), np.nan) if est.vehicle_var is None else est.vehicle_var
    with np.errstate(invalid="ignore"):
        sd = np.sqrt(np.clip(var, 0.0, None))
    tv = log.truth[:, 3:5]
    along, sig_along = track_frame(err_pos[:, :2], C[:, :2, :2],
                                   np.arctan2(tv[:, 1], tv[:, 0]))
    nees_att = nees_series(err_rot, C[:, 3:, 3:])
    nees_att[0] = np.nan  # epoch 0 is the prior
    f32 = {"sig_vel": sd[:, 3:6], "err_bias": est.bias - log.truth[:, 10:16],
           "sig_bias": sd[:, 9:15], "nees_att": nees_att, "err_track": along,
           "sig_track": sig_along}
    return {**{k: np.asarray(v, dtype=np.float32) for k, v in f32.items()},
            "nis_epoch": est.nis_epoch, "map_series": est.map_series}


def track_of(est: DroneEstimate) -> DroneTrack:
    return DroneTrack(est.name, est.p, est.q, est.pose_cov, est.bias, est.landmark_ids,
                      est.landmarks, est.landmark_cov)


# --------------------------------------------------------------------------- summary

def _loop_masks(times: Array, loop_end_times: Sequence[float]) -> list[Array]:
    out, start = [], -np.inf
    for end in loop_end_times:
        out.append((times > start) & (times <= end + 1e-9))
        start = end
    return out


def _per_loop(norm: Array, loops: list[Array]) -> dict[str, Any]:
    """Position error RMS and largest error (m) per lap from the error norms (R, E), with
    ``loop_epochs`` (the epochs of each lap); a lap with no finite error gets ``None`` and
    the reason (``loop_pos_rmse_m_reason``; a world's laps are checked to hold an epoch
    when its truth is flown, :func:`slam.kinds.drone.truth.empty_lap`)."""
    values = [norm[:, m][np.isfinite(norm[:, m])] for m in loops]
    out: dict[str, Any] = {
        "loop_epochs": [int(m.sum()) for m in loops],
        "loop_pos_rmse_m": [float(np.sqrt(np.mean(v**2))) if v.size else None for v in values],
        "loop_pos_max_err_m": [float(np.max(v)) if v.size else None for v in values]}
    empty = [i + 1 for i, v in enumerate(values) if not v.size]
    if empty:
        why = f"no finite position error in lap(s) {empty} (loop_epochs)"
        out["loop_pos_rmse_m_reason"] = out["loop_pos_max_err_m_reason"] = why
    return out


def summarize_scores(scores: list[DroneScores], times: Array | None = None,
                     loop_end_times: Sequence[float] = ()) -> dict[str, Any]:
    """Monte Carlo summary of one estimator (a ``summary.json`` entry).

    Diverged runs are counted and left out of every statistic.
    """
    good, out = scored_runs(scores)
    if not good:
        return out
    ep = np.stack([s.err_pos for s in good])  # (R, E, 3)
    out["pos_rmse_m"] = float(np.sqrt(np.nanmean(np.sum(ep**2, axis=2))))
    out["pos_rmse_xy_m"] = float(np.sqrt(np.nanmean(np.sum(ep[..., :2] ** 2, axis=2))))
    out["pos_err_range_m"] = {a: [float(np.nanmin(ep[..., i])), float(np.nanmax(ep[..., i]))]
                              for i, a in enumerate(AXES)}
    out["pos_rmse_axis_m"] = {a: float(np.sqrt(np.nanmean(ep[..., i] ** 2)))
                              for i, a in enumerate(AXES)}
    ev = np.stack([s.err_vel for s in good])
    out["vel_rmse_mps"] = float(np.sqrt(np.nanmean(np.sum(ev**2, axis=2))))
    ea = np.stack([s.err_att for s in good])
    out["att_rmse_deg"] = {a: float(np.degrees(np.sqrt(np.nanmean(ea[..., i] ** 2))))
                           for i, a in enumerate(ATT_AXES)}
    out["heading_rmse_deg"] = out["att_rmse_deg"]["yaw"]
    if times is not None and len(loop_end_times) > 1:
        out.update(_per_loop(np.linalg.norm(ep, axis=2),
                             _loop_masks(np.asarray(times), loop_end_times)))
    lm = np.concatenate([s.lm_err for s in good])
    if lm.size:
        out["landmark_rmse_m"] = float(np.sqrt(np.mean(lm**2)))
        out["landmarks_mapped_mean"] = float(np.mean([len(s.lm_err) for s in good]))
    out.update(anees_entries(np.stack([s.nees_pos for s in good]), 3, full=True))
    out.update(anees_entries(np.stack([s.nees_pose for s in good]), 6, "anees_pose6"))
    out.update(nis_and_timing(good))
    return out


