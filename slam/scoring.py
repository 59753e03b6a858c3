r"""Scores: errors, consistency (NEES/NIS) and their Monte Carlo summaries.

For :math:`R` runs of a 3-dof vehicle pose the normalised estimation error squared
:math:`\epsilon_k = e_k^\top P_k^{-1} e_k` averaged over runs and divided by the
dimension is, for a consistent filter, :math:`\chi^2_{3R}/(3R)` distributed at each
step (Bar-Shalom, Li & Kirubarajan 2001, §5.4); ``anees`` is its time average, and
``anees_bounds_95`` the per-step two-sided 95 % band.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from estimators import wrap_angle
from slam.results import Array, RunScores

COND_LIMIT = 1e12  # covariances more ill-conditioned than this get no NEES


def pose_errors(poses: Array, truth: Array) -> Array:
    """``poses - truth`` with the heading difference wrapped; shape (K + 1, 3)."""
    err = poses - truth
    err[:, 2] = wrap_angle(err[:, 2])
    return err


def nees_series(err: Array, cov: Array) -> Array:
    """NEES per step; NaN where ``cov`` is absent, non-finite or near-singular."""
    out = np.full(err.shape[0], np.nan)
    ok = np.all(np.isfinite(cov), axis=(1, 2)) & np.all(np.isfinite(err), axis=1)
    if ok.any():
        c = cov[ok]
        w = np.linalg.eigvalsh(c)
        good = w[:, 0] > w[:, -1] / COND_LIMIT
        idx = np.flatnonzero(ok)[good]
        e = err[idx]
        out[idx] = np.einsum("ki,ki->k", e, np.linalg.solve(cov[idx], e[..., None])[..., 0])
    return out


def reduce_run(name: str, poses: Array, pose_cov: Array, truth: Array, landmark_ids: Array,
               landmarks: Array, true_landmarks: Array | None, nis: Array, nis_dof: Array,
               time_s: float, diverged: bool = False, failure: str | None = None
               ) -> RunScores:
    """Reduce one estimator's output on one run to its :class:`RunScores`."""
    err = pose_errors(poses, truth)
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.diagonal(pose_cov, axis1=1, axis2=2))
    if true_landmarks is not None and len(landmark_ids):
        known = landmark_ids >= 0
        lm_err = np.linalg.norm(landmarks[known] - true_landmarks[landmark_ids[known]], axis=1)
    else:
        lm_err = np.zeros(0)
    return RunScores(name, err, sigma, nees_series(err, pose_cov), lm_err,
                     np.asarray(nis, float), np.asarray(nis_dof, int), float(time_s),
                     poses.shape[0] - 1, diverged, failure)


def anees_band(runs: int, dof: int = 3, level: float = 0.95) -> tuple[float, float]:
    """Two-sided band of the run-averaged NEES divided by ``dof``."""
    a = (1.0 - level) / 2.0
    n = runs * dof
    return float(chi2.ppf(a, n) / n), float(chi2.ppf(1.0 - a, n) / n)


def summarize(scores: list[RunScores], *, with_heading: bool = True) -> dict:
    """Monte Carlo summary of one estimator (a ``summary.json`` filter entry).

    Diverged runs are counted and left out of every error statistic.
    """
    good = [s for s in scores if not s.diverged]
    out: dict = {"runs_scored": len(good), "diverged_runs": len(scores) - len(good)}
    if not good:
        out["failures"] = sorted({s.failure or "" for s in scores})
        return out
    err = np.stack([s.err for s in good])  # (R, K + 1, 3)
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
    nees = np.stack([s.nees for s in good])  # (R, E)
    finite = np.isfinite(nees)
    count = finite.sum(axis=0)
    per_step = np.where(count > 0, np.where(finite, nees, 0.0).sum(axis=0)
                        / np.maximum(count, 1), np.nan) / 3.0
    if np.isfinite(per_step).any():
        lo, hi = anees_band(len(good))
        valid = per_step[np.isfinite(per_step)]
        out["anees"] = float(valid.mean())
        out["anees_bounds_95"] = [lo, hi]
        out["anees_steps_inside_95"] = float(np.mean((valid >= lo) & (valid <= hi)))
    out.update(nis_and_timing(good))
    return out


def nis_and_timing(good: list) -> dict:
    """``nis_mean`` (NIS per measurement dof over all updates), ``time_per_step_s`` and
    ``time_per_run_s`` of runs with ``nis``, ``nis_dof``, ``steps`` and ``time_s``."""
    out: dict = {}
    nis = np.concatenate([s.nis for s in good])
    if nis.size:
        dof = np.concatenate([s.nis_dof for s in good])
        out["nis_mean"] = float(np.mean(nis / dof))
    steps = sum(s.steps for s in good)
    out["time_per_step_s"] = float(sum(s.time_s for s in good) / max(steps, 1))
    out["time_per_run_s"] = float(np.mean([s.time_s for s in good]))
    return out
