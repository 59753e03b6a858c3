r"""Scores of the fixed-wing campaign: per-run reductions and their Monte Carlo summaries.

Errors are estimate minus truth at each estimator's own epochs (EA: the accelerometer/
magnetometer epochs; INS and the smoother: the GNSS epochs): Z-Y-X roll, pitch, heading
(wrapped; heading = yaw from East, the error is the same from North), and for the INS
filters and the smoother east/north/up position and velocity.  [Fixed-wing EA-UKF]
Table 1 reports *mean errors*; we read them as the mean absolute error over the epochs
and the runs (``table1``).  Consistency: NEES of ``[δp, δv, δθ]`` (9 dof) for the INS
filters and the smoother, of the Euler angles (3 dof) for the EA filters, against the
two-sided 95 % χ² band of the run average (:func:`slam.scoring.anees_stats`).  Turn
epochs: the true heading rate above ``[scoring] turn_rate_deg_s``; accelerating epochs:
outside turns, the true acceleration above ``accel_mps2``; the rest is steady flight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.spaces import UnitQuaternion
from slam.results import EstimatorRun
from slam.scoring import anees_entries, nees_series, scored_runs, timing

Array = NDArray[np.float64]
DEG = math.pi / 180.0
AXES = ("roll", "pitch", "heading")
_QUAT = UnitQuaternion()


@dataclass(frozen=True)
class FwScores(EstimatorRun):
    """One estimator on one run, reduced (radians, m, m/s; at its epochs ``times``).

    err_att, sig_att : (M, 3); err_pos, err_vel : (M, 3) or None (EA filters);
    turn, accel : (M,) True at turn / accelerating epochs; nees : (M,) with ``nees_dof``;
    cycles : predict + update cycles; note : why the covariance is missing (the smoother's
    marginals), if it is; sig_pos, sig_vel : (M, 3) own σ of err_pos, err_vel or None.
    The :class:`~slam.results.EstimatorRun` fields:
    nis per update (``nis_dof`` each); time_s over the ``cycles`` (smoother: its solve).
    """

    name: str
    times: Array
    err_att: Array
    sig_att: Array
    err_pos: Array | None
    err_vel: Array | None
    turn: Array
    accel: Array
    nees: Array
    nees_dof: int
    cycles: int
    note: str | None = None
    sig_pos: Array | None = None
    sig_vel: Array | None = None


def nav_nees(p_err: Array, v_err: Array, qh: Array, q_true: Array, cov9: Array) -> Array:
    """NEES of the tangent error ``truth ⊟ estimate`` = ``[-δp, -δv, Log(q̂* ⊗ q)]``
    (9 dof; ``p_err``, ``v_err`` are estimate minus truth)."""
    body = np.full(p_err.shape, np.nan)
    ok = np.all(np.isfinite(qh), axis=1)
    body[ok] = _QUAT.local(qh[ok], q_true[ok])
    return nees_series(np.hstack([-p_err, -v_err, body]), cov9)


def final_check(err_att: Array, diverged: bool, failure: str | None, limit: float
                ) -> tuple[bool, str | None]:
    """A run whose last attitude error exceeds ``limit`` counts as diverged."""
    last = float(np.max(np.abs(err_att[-1]))) if np.all(np.isfinite(err_att[-1])) else math.inf
    if diverged or last <= limit:
        return diverged, failure
    return True, (f"final attitude error {math.degrees(last):.3g} deg exceeds "
                  f"{math.degrees(limit):.3g} deg")


def _rms(x: Array) -> float | None:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else None


def _mean_abs(x: Array) -> float | None:
    x = x[np.isfinite(x)]
    return float(np.mean(np.abs(x))) if x.size else None


def table1(good: list[FwScores]) -> dict[str, float | None]:
    """The paper's Table 1 columns: mean |error| over epochs and runs."""
    att = np.stack([s.err_att for s in good])
    out: dict[str, float | None] = {"heading_deg": _mean_abs(att[..., 2] / DEG)}
    if good[0].err_pos is not None:
        p = np.stack([s.err_pos for s in good])
        v = np.stack([s.err_vel for s in good])
        out.update(longitude_m=_mean_abs(p[..., 0]), latitude_m=_mean_abs(p[..., 1]),
                   east_velocity_mps=_mean_abs(v[..., 0]),
                   north_velocity_mps=_mean_abs(v[..., 1]))
    return out


def turn_split(good: list[FwScores]) -> dict[str, dict[str, Any]]:
    """RMS roll / pitch / heading error (deg) in turns, accelerating outside turns and in
    steady flight, each with ``epochs``: the estimator's epochs in the segment (per run;
    the RMS is ``None`` when it is 0, see :mod:`slam.nulls`)."""
    att = np.stack([s.err_att for s in good]) / DEG
    masks = {"turns": good[0].turn, "accelerating": good[0].accel,
             "steady": ~good[0].turn & ~good[0].accel}
    return {seg: {**{a: _rms(att[:, mask, i]) for i, a in enumerate(AXES)},
                  "epochs": int(np.sum(mask))}
            for seg, mask in masks.items()}


def _consistency(good: list[FwScores]) -> dict[str, Any]:
    out: dict[str, Any] = {"nees_dof": good[0].nees_dof}
    out.update(anees_entries(np.stack([s.nees for s in good]), good[0].nees_dof))
    nis = np.concatenate([s.nis for s in good])
    if nis.size and good[0].nis_dof:
        out["nis_mean"] = float(np.mean(nis) / good[0].nis_dof)
    return out


def summarize_scores(scores: list[FwScores]) -> dict[str, Any]:
    """Monte Carlo summary of one estimator; diverged runs are counted with their
    reasons and left out of every statistic."""
    good, out = scored_runs(scores)
    if not good:
        return out
    notes = [s.note for s in good if s.note]
    if notes:
        out["no_covariance_runs"] = len(notes)
        out["no_covariance_reasons"] = sorted(set(notes))
    att = np.stack([s.err_att for s in good]) / DEG
    out["att_rmse_deg"] = {a: _rms(att[..., i]) for i, a in enumerate(AXES)}
    out["table1"] = table1(good)
    out["turn_split_rmse_deg"] = turn_split(good)
    if good[0].err_pos is not None:
        p = np.stack([s.err_pos for s in good])
        out["pos_rmse_m"] = _rms(np.linalg.norm(p, axis=-1))
    out.update(_consistency(good))
    out.update(timing(good))
    return out
