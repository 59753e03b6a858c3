r"""Scores of the ship campaign: per-run reductions and their Monte Carlo summaries.

Errors are estimate minus truth of the Z-Y-X Euler angles (roll, pitch, yaw; wrapped), in
arcminutes as the paper gives them; the estimator's own standard deviations of those
angles come from its tangent covariance through the Euler-angle Jacobian.  Consistency is
the 6-dof NEES of ``[δθ, δα]`` (body-frame attitude error ``Log(q̂* ⊗ q)`` and drift error
``α - α̂``) and the 3-dof NEES of ``δθ`` alone, against the two-sided 95 % χ² band of their
run average (Bar-Shalom, Li & Kirubarajan 2001).

Time to converge: the first vector epoch after which both |roll| and |pitch| errors stay
below the world's bound (10′) to the end of the run (NaN if they are above it at the end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.euler import euler_zyx_errors
from nav.spaces import UnitQuaternion
from slam.kinds.ship.simulate import ShipLog
from slam.results import EstimateSeries, EstimatorRun
from slam.scoring import anees_stats, nees_series, scored_runs, timing

Array = NDArray[np.float64]

AXES = ("roll", "pitch", "yaw")
ARCMIN = math.pi / 180.0 / 60.0
DEG_H = math.pi / 180.0 / 3600.0
_QUAT = UnitQuaternion()


@dataclass(frozen=True)
class ShipScores(EstimatorRun):
    """One estimator on one run, reduced (radians, rad/s; at the vector epochs).

    err : (M, 3) roll/pitch/yaw error; sigma : (M, 3) own std of those angles;
    err_bias : (M, 3) ``α - α̂``; nees6, nees3 : (M,) NEES of ``[δθ, δα]`` and ``δθ``;
    cycles : predict + update cycles; moments : (M, 3) skewness, kurtosis and refused flag
    of a HoMM filter with predicted moments (``None`` otherwise).  The
    :class:`~slam.results.EstimatorRun` fields:
    nis (M,) per update with ``nis_dof``; time_s over the ``cycles`` (the smoother: its
    solve).
    """

    name: str
    err: Array
    sigma: Array
    err_bias: Array
    nees6: Array
    nees3: Array
    cycles: int
    moments: Array | None = None


def score(est: EstimateSeries, log: ShipLog, divergence_rad: float) -> ShipScores:
    """Reduce an estimator's series to :class:`ShipScores` against the log's truth."""
    q_true, b_true = log.update_truth_q, log.update_truth_bias
    qh, P = est.means[:, :4], est.covs
    err, sig = euler_zyx_errors(qh, P[:, :3, :3], q_true)
    body = np.full((len(q_true), 3), np.nan)
    ok = np.all(np.isfinite(qh), axis=1)
    body[ok] = _QUAT.local(qh[ok], q_true[ok])
    e6 = np.hstack([body, b_true - est.means[:, 4:]])
    nees6 = nees_series(e6, P)
    nees3 = nees_series(body, P[:, :3, :3])
    diverged, failure = est.diverged, est.failure
    final = float(np.linalg.norm(body[-1]))
    if not diverged and not final <= divergence_rad:
        diverged, failure = True, (f"final attitude error {math.degrees(final):.3g} deg exceeds "
                                   f"{math.degrees(divergence_rad):.3g} deg")
    return ShipScores(est.name, err, sig, e6[:, 3:], nees6, nees3, est.cycles,
                      getattr(est, "moments", None), nis=est.nis,
                      nis_dof=est.nis_dof, time_s=est.time_s, diverged=diverged,
                      failure=failure, extra_time_s=est.extra_time_s)


def settle_times(ok: Array, times: Array) -> Array:
    """Per run (rows of ``ok`` (R, M), True where within bounds): the first epoch after
    which ``ok`` holds to the end; NaN where it fails at the last epoch."""
    bad = ~ok
    any_bad = bad.any(axis=1)
    last = bad.shape[1] - 1 - np.argmax(bad[:, ::-1], axis=1)
    out = np.where(any_bad, times[np.minimum(last + 1, len(times) - 1)], times[0])
    return np.where(bad[:, -1], np.nan, out)


def _per_axis(values: Array) -> dict[str, float]:
    return {a: float(v / ARCMIN) for a, v in zip(AXES, values)}


def _quantiles(x: Array) -> dict[str, float | None]:
    """Median, 95th percentile and max of the finite values of ``x`` (None if none)."""
    x = x[np.isfinite(x)]
    if not x.size:
        return {"median": None, "p95": None, "max": None}
    return {"median": float(np.median(x)), "p95": float(np.percentile(x, 95)),
            "max": float(np.max(x))}


def error_stats(e: Array, times: Array, steady: Array, bound: float) -> dict[str, Any]:
    """Error statistics of stacked errors ``e`` (R, M, 3) in arcmin (module docstring)."""
    out: dict[str, Any] = {
        "att_rms_arcmin": _per_axis(np.sqrt(np.nanmean(e**2, axis=(0, 1)))),
        "att_rms_steady_arcmin": _per_axis(np.sqrt(np.nanmean(e[:, steady] ** 2, axis=(0, 1)))),
        "att_max_abs_steady_p95_arcmin": _per_axis(
            np.percentile(np.nanmax(np.abs(e[:, steady]), axis=1), 95, axis=0)),
    }
    final = np.abs(e[:, -1]) / ARCMIN
    out["final_abs_arcmin"] = {a: {"mean": float(np.mean(final[:, i])),
                                   "rms": float(np.sqrt(np.mean(final[:, i] ** 2))),
                                   **_quantiles(final[:, i])} for i, a in enumerate(AXES)}
    tc = settle_times(np.all(np.abs(e[:, :, :2]) < bound, axis=2), times)
    out["converge_roll_pitch_s"] = _converge(tc)
    out["converge_yaw_s"] = _converge(settle_times(np.abs(e[:, :, 2]) < bound, times))
    return out


def _converge(tc: Array) -> dict[str, Any]:
    """Quantiles of the runs' times to converge over the ``converged_runs``, and the runs
    that ``never`` do (quantiles ``None`` when no run converges)."""
    ok = np.isfinite(tc)
    return {**_quantiles(tc), "never": int(np.sum(~ok)), "converged_runs": int(np.sum(ok))}


def _consistency(good: list[ShipScores], steady: Array) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, dof in (("nees6", 6), ("nees3", 3)):
        stats = anees_stats(np.stack([getattr(s, key) for s in good]), dof)
        if stats:
            suffix = "" if dof == 6 else "_att"
            out[f"anees{suffix}"] = stats["value"]
            out[f"anees{suffix}_bounds_95"] = stats["band"]
            out[f"anees{suffix}_inside_95"] = stats["inside"]
            out[f"anees{suffix}_above_95"] = stats["above"]
    nis = np.stack([s.nis for s in good])[:, steady]
    if np.isfinite(nis).any() and good[0].nis_dof:
        out["nis_mean_steady"] = float(np.nanmean(nis) / good[0].nis_dof)
    return out


def summarize_scores(scores: list[ShipScores], times: Array, steady_from: float,
                     bound: float) -> dict[str, Any]:
    """Monte Carlo summary of one estimator (a ``summary.json`` entry); diverged runs are
    counted, with their reasons, and left out of every statistic."""
    good, out = scored_runs(scores)
    if not good:
        return out
    steady = times >= steady_from
    out.update(error_stats(np.stack([s.err for s in good]), times, steady, bound))
    eb = np.stack([s.err_bias for s in good])
    out["bias_rmse_deg_h"] = float(np.sqrt(np.nanmean(eb**2)) / DEG_H)
    out["bias_final_rmse_deg_h"] = float(np.sqrt(np.nanmean(eb[:, -1] ** 2)) / DEG_H)
    out.update(_consistency(good, steady))
    out.update(timing(good))
    return out


def homm_moments(scores: list[ShipScores], times: Array) -> dict[str, Any]:
    """What a HoMM filter with predicted moments drew with ([Ding 2017] φ₁√N, φ₂N;
    :mod:`estimators.homm`), over its runs that did not diverge: the kurtosis and skewness
    quantiles over every update after the first (5th, 50th, 95th percentile, min, max)
    and over the first 30 s, and the refused estimates (fallbacks to the stated moments)
    out of the predictions; ``{}`` for any other estimator."""
    good = [s for s in scores if not s.diverged and s.moments is not None]
    if not good:
        return {}
    m = np.stack([s.moments for s in good])[:, 1:]  # (R, M-1, 3): epoch 0 has none
    early = times[1:] <= 30.0

    def q(x: Array) -> dict[str, float]:
        x = x[np.isfinite(x)]
        return {"p5": float(np.percentile(x, 5)), "median": float(np.median(x)),
                "p95": float(np.percentile(x, 95)), "min": float(x.min()),
                "max": float(x.max())}

    return {"runs": len(good), "kurtosis": q(m[..., 1]), "skewness": q(m[..., 0]),
            "kurtosis_first_30s": q(m[:, early, 1]),
            "fallbacks": int(np.nansum(m[..., 2])),
            "predictions": int(np.sum(np.isfinite(m[..., 1])))}
