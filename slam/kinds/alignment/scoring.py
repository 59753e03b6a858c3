r"""Scores of the alignment campaign: per-run series, their Monte Carlo summaries, and the
theoretical alignment limits of the world.

Errors are the residual misalignment of the corrected attitude, East, North and azimuth
(Up) components of :math:`\mathrm{Log}(q_{est} \otimes q^*)`, in arcminutes as the paper
gives them.  Settling time: on the Monte Carlo RMS curve of each axis, the first epoch
after which the RMS stays within ``settle_factor`` (1.2) × its final value.  Consistency:
the 3-dof misalignment NEES, the 2-dof NEES of the level axes alone and the 13-dof NEES
of the whole error state against the two-sided 95 % χ² band of their run average
(Bar-Shalom, Li & Kirubarajan 2001).

Theoretical limits of stationary alignment (e.g. Titterton & Weston, *Strapdown Inertial
Navigation Technology*, §10): the level misalignment settles where the accelerometer bias
is balanced, :math:`\phi_E \approx -\nabla_N/g`, :math:`\phi_N \approx \nabla_E/g`; the
azimuth where the east gyro drift is balanced by the Earth rate it must sense,
:math:`\phi_U \approx \varepsilon_E/(\Omega\cos L)` - meaningless when the drift exceeds
:math:`\Omega\cos L` (no heading can be found by gyrocompassing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.strapdown import EARTH_RATE, G0
from slam.kinds.alignment.world import AlignmentWorld
from slam.results import EstimatorRun
from slam.scoring import anees_entries, scored_runs, timing

Array = NDArray[np.float64]

AXES = ("east", "north", "azimuth")
ARCMIN = math.pi / 180.0 / 60.0
DEG_H = math.pi / 180.0 / 3600.0


@dataclass(frozen=True)
class AlignScores(EstimatorRun):
    """One estimator on one run (radians, at the filter epochs; NaN where none).

    err, sigma : (M, 3) residual misalignment and own σ; nees : (M,) 3-dof; nees13 : (M,)
    whole error state; nees_level : (M,) 2-dof, the level axes (East, North) alone;
    cycles : predict + update cycles; note: why the covariance is missing (the
    smoother's marginals), if it is; fallbacks : H∞ updates whose existence condition
    failed (the Kalman update was taken) among ``updates``.  The
    :class:`~slam.results.EstimatorRun` fields: nis : (M,) with ``nis_dof``; time_s over
    the ``cycles`` (the smoother: its solve).
    """

    name: str
    err: Array
    sigma: Array
    nees: Array
    nees13: Array
    nees_level: Array
    cycles: int
    note: str | None = None
    fallbacks: int = 0
    updates: int = 0


def finite_mean(x: Array, axis: int | tuple[int, ...] | None = None) -> Array:
    """Mean of the finite values of ``x`` along ``axis``; NaN where there is none (what
    ``np.nanmean`` gives, without its empty-slice warning)."""
    ok = np.isfinite(x)
    count = ok.sum(axis=axis)
    total = np.where(ok, x, 0.0).sum(axis=axis)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def settle_time(rms: Array, times: Array, factor: float) -> float | None:
    """First time after which the finite ``rms`` stays within ``factor`` × its last
    value (``None`` if no finite value)."""
    ok = np.isfinite(rms)
    if not ok.any():
        return None
    r, t = rms[ok], times[ok]
    outside = r > factor * r[-1]
    if not outside.any():
        return float(t[0])
    last = len(r) - 1 - int(np.argmax(outside[::-1]))
    return float(t[min(last + 1, len(t) - 1)])


def _per_axis(v: Array) -> dict[str, float]:
    return {a: float(x / ARCMIN) for a, x in zip(AXES, v)}


def _windows(rms_sq: Array, times: Array, n: int = 4) -> dict[str, Any]:
    """RMS per axis (arcmin) over ``n`` equal windows of the run, with ``epochs``: the
    epochs with an estimate in each window (``None`` where it is 0, :mod:`slam.nulls`)."""
    edges = np.linspace(times[0], times[-1], n + 1)
    sels = [(times > a) & (times <= b) for a, b in zip(edges[:-1], edges[1:])]
    out: dict[str, Any] = {"windows_s": [[float(a), float(b)] for a, b in
                                         zip(edges[:-1], edges[1:])],
                           "epochs": [int(np.all(np.isfinite(rms_sq[sel]), axis=1).sum())
                                      for sel in sels]}
    for i, axis in enumerate(AXES):
        out[axis] = [float(np.sqrt(finite_mean(rms_sq[sel, i])) / ARCMIN) for sel in sels]
    return out


def error_stats(e: Array, times: Array, factor: float) -> dict[str, Any]:
    """Error statistics (arcmin, s) of stacked errors ``e`` (R, M, 3)."""
    rms_sq = finite_mean(e**2, axis=0)  # (M, 3)
    rms = np.sqrt(rms_sq)
    ok = np.all(np.isfinite(rms), axis=1)
    last = int(np.flatnonzero(ok)[-1])
    final = np.abs(e[:, last])
    half = ok & (times >= times[-1] / 2)
    slope = np.polyfit(times[half], rms[half, 0], 1)[0] if half.sum() > 2 else None
    trend = {"east_trend_arcmin_per_100s": None if slope is None
             else float(slope * 100.0 / ARCMIN)}
    if slope is None:
        trend["east_trend_arcmin_per_100s_reason"] = (
            f"{int(half.sum())} epochs with an estimate in the second half of the run; the "
            "trend needs 3")
    return {
        "final_rms_arcmin": _per_axis(rms[last]),
        "final_mean_abs_arcmin": _per_axis(np.mean(final, axis=0)),
        "settle_s": {a: settle_time(rms[:, i], times, factor) for i, a in enumerate(AXES)},
        "rms_window_arcmin": _windows(rms_sq, times),
        **trend,
        "rms_whole_arcmin": _per_axis(np.sqrt(finite_mean(rms_sq, axis=0))),
    }


def _consistency(good: list[AlignScores]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, attr, dof in (("anees", "nees", 3), ("anees_state", "nees13", 13),
                           ("anees_level", "nees_level", 2)):
        out.update(anees_entries(np.stack([getattr(s, attr) for s in good]), dof, key))
    nis = np.stack([s.nis for s in good])
    if np.isfinite(nis).any() and good[0].nis_dof:
        out["nis_mean"] = float(np.nanmean(nis) / good[0].nis_dof)
    return out


def summarize_scores(scores: list[AlignScores], times: Array, factor: float
                     ) -> dict[str, Any]:
    """Monte Carlo summary of one estimator (a ``summary.json`` entry); diverged runs are
    counted, with their reasons, and left out of every statistic."""
    good, out = scored_runs(scores)
    if not good:
        return out
    notes = [s.note for s in good if s.note]
    if notes:
        out["no_covariance_runs"] = len(notes)
        out["no_covariance_reasons"] = sorted(set(notes))
    out.update(error_stats(np.stack([s.err for s in good]), times, factor))
    out.update(_consistency(good))
    out.update(timing(good))
    return out


def limits(world: AlignmentWorld) -> dict[str, Any]:
    """The theoretical alignment limits from the world's numbers (module docstring)."""
    m = world.imu
    accel = math.hypot(m.accel_bias_mps2, m.accel_markov_mps2)
    drift = math.hypot(m.gyro_bias_rad_s, m.gyro_markov_rad_s)
    horizontal = EARTH_RATE * math.cos(world.site.latitude_rad)
    ratio = drift / horizontal
    unobservable = {} if ratio < 1.0 else {"azimuth_limit_deg_reason": (
        f"the gyro drift ({drift / DEG_H:.3g} °/h) is not below the horizontal Earth rate "
        f"({horizontal / DEG_H:.3g} °/h): azimuth is not observable by gyrocompassing")}
    return {
        "accel_bias_sigma_g": accel / G0,
        "tilt_limit_arcmin": accel / G0 / ARCMIN,
        "gyro_drift_sigma_deg_h": drift / DEG_H,
        "earth_rate_horizontal_deg_h": horizontal / DEG_H,
        "drift_over_earth_rate": ratio,
        "azimuth_limit_deg": math.degrees(math.asin(ratio)) if ratio < 1.0 else None,
        **unobservable,
        "azimuth_observable": ratio < 1.0,
    }
