r"""Scores: errors, consistency (NEES/NIS) and their Monte Carlo summaries.

For :math:`R` runs of a 3-dof vehicle pose the normalised estimation error squared
:math:`\epsilon_k = e_k^\top P_k^{-1} e_k` averaged over runs and divided by the
dimension is, for a consistent filter, :math:`\chi^2_{3R}/(3R)` distributed at each
step (Bar-Shalom, Li & Kirubarajan 2001, §5.4); ``anees`` is its time average, and
``anees_bounds_95`` the per-step two-sided 95 % band.  The NEES, NIS and χ² bands
themselves are the library's (:mod:`estimators.consistency`), re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, TypeVar

import numpy as np

from estimators.consistency import (  # noqa: F401  (the kinds' and tests' import path)
    COND_LIMIT,
    anees_band,
    anees_stats,
    chi2_ppf,
    nees_series,
    nis_stats,
    per_epoch_anees,
)
from slam.results import Array


class Ended(Protocol):
    """Per-run scores that say whether (and why) the run diverged."""

    @property
    def diverged(self) -> bool: ...

    @property
    def failure(self) -> str | None: ...


S = TypeVar("S", bound=Ended)


def pad_stack(arrays: Sequence[Array], length: int | None = None) -> Array:
    """Per-run series of possibly different lengths (their first axis: the epochs) as one
    (R, E, ...) array, NaN after a run's last epoch; ``E`` is ``length`` (longer runs cut)
    or the longest run's.  Runs differ in length when their truths do (a vehicle with an
    uncertain start reaches the waypoints at other times)."""
    arrays = [np.asarray(a, dtype=float) for a in arrays]
    E = max(len(a) for a in arrays) if length is None else length
    out = np.full((len(arrays), E) + arrays[0].shape[1:], np.nan)
    for i, a in enumerate(arrays):
        out[i, :min(len(a), E)] = a[:E]
    return out


def track_frame(err_xy: Array, cov_xy: Array, heading: Array) -> tuple[Array, Array]:
    """Position errors ``err_xy`` (E, 2) and their covariances ``cov_xy`` (E, 2, 2) in the
    frame of ``heading`` (E,): ``[along-track, cross-track]`` errors and standard
    deviations (cross-track positive to the left of the direction of travel)."""
    c, s = np.cos(heading), np.sin(heading)
    R = np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)  # (E, 2, 2) world->track
    err = np.einsum("kij,kj->ki", R, err_xy)
    with np.errstate(invalid="ignore"):
        cov = R @ cov_xy @ np.swapaxes(R, -1, -2)
        sig = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
    return err, sig


def scored_runs(scores: Sequence[S]) -> tuple[list[S], dict[str, Any]]:
    """The runs (an estimator's per-run scores) that did not diverge, and the first
    entries of its summary: ``runs_scored``, ``diverged_runs`` and, if any diverged, the
    sorted ``failures`` (every statistic leaves the diverged runs out)."""
    good = [s for s in scores if not s.diverged]
    out: dict[str, Any] = {"runs_scored": len(good), "diverged_runs": len(scores) - len(good)}
    if len(good) < len(scores):
        out["failures"] = sorted({s.failure or "" for s in scores if s.diverged})
    return good, out


def anees_entries(nees: Array, dof: int, key: str = "anees", *, full: bool = False
                  ) -> dict[str, Any]:
    """The summary entries of :func:`anees_stats` of ``nees`` (R, E) under ``key``: the
    ANEES, ``key_bounds_95``, ``key_steps_inside_95`` and ``key_steps_above_95`` (none
    when there is no NEES); ``full`` adds ``key_dof`` after the ANEES and
    ``key_distance_to_band`` at the end."""
    stats = anees_stats(nees, dof)
    if not stats:
        return {}
    out: dict[str, Any] = {key: stats["value"]}
    if full:
        out[f"{key}_dof"] = dof
    out.update({f"{key}_bounds_95": stats["band"], f"{key}_steps_inside_95": stats["inside"],
                f"{key}_steps_above_95": stats["above"]})
    if full:
        out[f"{key}_distance_to_band"] = stats["distance"]
    return out


def timing(good: Sequence[Any], per: str = "cycle") -> dict[str, float]:
    """``time_per_<per>_s``, the runs' wall time over their ``<per>s`` (the ``cycles`` or
    ``steps`` attribute), and ``time_per_run_s``."""
    count = sum(getattr(s, per + "s") for s in good)
    return {f"time_per_{per}_s": float(sum(s.time_s for s in good) / max(count, 1)),
            "time_per_run_s": float(np.mean([s.time_s for s in good]))}


def nis_and_timing(good: list) -> dict:
    """``nis_mean`` (NIS per measurement dof over all updates), ``time_per_step_s`` and
    ``time_per_run_s`` of runs with ``nis``, ``nis_dof``, ``steps`` and ``time_s``."""
    out: dict = {}
    nis = np.concatenate([s.nis for s in good])
    if nis.size:
        dof = np.concatenate([s.nis_dof for s in good])
        out["nis_mean"] = float(np.mean(nis / dof))
    out.update(timing(good, "step"))
    return out


def landmark_anees_entries(series: Sequence[Any], length: int | None = None,
                           key: str = "landmark_anees") -> dict[str, Any]:
    r"""The map's consistency in the summary keys of :func:`anees_entries`, from the runs'
    :class:`~slam.mapping.map_series.MapSeries` (their ``nees`` sums, ``nees_count`` and
    ``dof``), padded to ``length`` epochs (default: the longest run's).

    At epoch :math:`k` the runs hold :math:`n_k` scored landmark blocks whose NEES sum to
    :math:`S_k`; for a consistent filter :math:`S_k \sim \chi^2_{d n_k}`, so
    :math:`a_k = S_k / (d n_k)` has the band of :func:`anees_band` with :math:`d n_k`
    degrees of freedom (what ``landmarks.png`` draws).  ``key`` is the mean of
    :math:`a_k` over the epochs with a landmark, ``key_bounds_95`` the band at the median
    :math:`n_k` (the count changes as landmarks are added), ``key_steps_inside_95`` /
    ``key_steps_above_95`` the fractions of those epochs inside / above their own band;
    ``{}`` without any scored landmark."""
    if not series:
        return {}
    nees = pad_stack([np.asarray(m.nees, dtype=float) for m in series], length)
    count = pad_stack([np.asarray(m.nees_count, dtype=float) for m in series], length)
    dof = int(series[0].dof)
    total_n = np.nansum(count, axis=0)
    ok = total_n > 0
    if not ok.any():
        return {}
    n = total_n[ok]
    value = np.nansum(nees, axis=0)[ok] / (dof * n)
    alpha = 0.025
    lo, hi = chi2_ppf(alpha, dof * n) / (dof * n), chi2_ppf(1 - alpha, dof * n) / (dof * n)
    mid = float(np.median(n))
    band = [float(chi2_ppf(alpha, dof * mid) / (dof * mid)),
            float(chi2_ppf(1 - alpha, dof * mid) / (dof * mid))]
    return {key: float(np.mean(value)), f"{key}_dof": dof, f"{key}_bounds_95": band,
            f"{key}_steps_inside_95": float(np.mean((value >= lo) & (value <= hi))),
            f"{key}_steps_above_95": float(np.mean(value > hi))}
