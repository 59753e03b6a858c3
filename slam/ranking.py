r"""Which filter is best on a campaign, by how much, and whether the difference is real.

Every filter of a campaign runs on the same simulated logs, so filters are compared run by
run (a paired comparison).  For a headline metric each filter ``i`` has a per-run mean
squared error :math:`m_{i,r}` (over the same epochs of the same run ``r``).  Over the
:math:`R` runs that every compared filter finished:

.. math::

    \bar m_i = \tfrac1R \textstyle\sum_r m_{i,r},\qquad b = \arg\min_i \bar m_i,\qquad
    d_{i,r} = m_{i,r} - m_{b,r},\qquad
    \bar d_i \pm s_i,\quad s_i = \frac{\mathrm{sd}(d_{i,\cdot})}{\sqrt R} .

Filter ``i`` is *significantly worse* than the best when :math:`\bar d_i > 2 s_i`
(:data:`LEVEL`), and *separated* from it when :math:`\bar d_i > 3 s_i` (:data:`SEPARATED`,
the level a world built to tell the filters apart must reach).  Ranks follow
:math:`\bar m_i`; a rank is only meaningful where the difference is significant, and the
report says so.  Filters whose mean MSEs agree to :data:`IDENTICAL_RTOL` are *equal*:
they share a rank (listed by name) whatever their z, since a difference of a millionth is
round-off, not a property of the filter.

With a single paired run (a recorded log is one run) the filters are still ordered by their
MSE, but :math:`s_i` is undefined: ``delta_se`` and ``z`` are ``None`` with their reason
and every verdict but ``best`` and ``equal`` is :data:`ONE_RUN` - no significance is
claimed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

LEVEL = 2.0
"""Standard errors a paired difference must exceed to be called significant."""
SEPARATED = 3.0
"""Standard errors a world made to separate the filters aims at."""
ONE_RUN = "one run: no significance"
"""The verdict of a filter ranked on a single paired run (no standard error exists)."""
IDENTICAL_RTOL = 1e-6
"""Filters whose mean MSEs differ by less than this fraction of the best one are *equal*:
a difference of a millionth is the arithmetic's (a differenced Jacobian, the order of a
sum), not the filter's, however many standard errors it is.  Equal filters share a rank
and are listed by name, so a ranking does not depend on round-off."""


@dataclass(frozen=True)
class Metric:
    """A headline metric: ``key`` in ``summary.json`` (``"position"``), a label for the
    reports, the unit of its root mean square, and each filter's per-run MSE (R,) in the
    unit squared (NaN for a run the filter did not finish)."""

    key: str
    label: str
    unit: str
    per_run_mse: Mapping[str, Array]


def per_run_mse(errors: Array, epochs: Array | None = None) -> Array:
    """Per-run mean squared error norm of stacked errors ``errors`` (R, E, k) (or (R, E)),
    over the epochs selected by the boolean ``epochs`` (E,) (all by default); NaN epochs
    are left out, a run without any finite epoch gives NaN."""
    e = np.asarray(errors, dtype=float)
    if e.ndim == 2:
        e = e[..., None]
    if epochs is not None:
        e = e[:, np.asarray(epochs, dtype=bool)]
    sq = np.sum(e**2, axis=2)
    finite = np.isfinite(sq)
    count = finite.sum(axis=1)
    total = np.where(finite, sq, 0.0).sum(axis=1)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def per_run(outcomes: Sequence[Any], name: str, fn: Callable[[Any], float]) -> Array:
    """``fn(scores)`` of estimator ``name`` in every outcome (an object with a ``scores``
    dict), NaN for a run it diverged on or did not run: one row of a :class:`Metric`."""
    out = np.full(len(outcomes), np.nan)
    for r, o in enumerate(outcomes):
        s = o.scores.get(name)
        if s is not None and not s.diverged:
            out[r] = fn(s)
    return out


def paired(a: Array, b: Array) -> dict[str, Any]:
    """The paired difference ``a - b`` of two per-run arrays over the runs where both are
    finite: ``mean``, ``se`` (``None`` below 2 runs, with ``se_reason``), ``runs`` and
    ``a_better_runs``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = np.isfinite(a) & np.isfinite(b)
    d = a[ok] - b[ok]
    out: dict[str, Any] = {"mean": float(d.mean()) if d.size else None, "runs": int(d.size),
                           "a_better_runs": int(np.sum(d < 0))}
    if d.size < 2:
        out["se"] = None
        out["se_reason"] = f"{d.size} paired run(s); a standard error needs at least 2"
    else:
        out["se"] = float(d.std(ddof=1) / math.sqrt(d.size))
    if not d.size:
        out["mean_reason"] = "no run finished by both"
    return out


def _ranks(mean: Array, names: Sequence[str]) -> list[int]:
    """Competition ranks by mean MSE, a filter within :data:`IDENTICAL_RTOL` of the one
    before it sharing its rank."""
    order = sorted(range(len(names)), key=lambda i: (mean[i], names[i]))
    ranks = [0] * len(names)
    lead = None
    for pos, i in enumerate(order, start=1):
        if lead is not None and abs(mean[i] - mean[lead]) <= IDENTICAL_RTOL * abs(mean[lead]):
            ranks[i] = ranks[lead]
        else:
            ranks[i], lead = pos, i
    return ranks


def _verdict(dm: float, se: float | None, best_mse: float) -> str:
    if abs(dm) <= IDENTICAL_RTOL * max(abs(best_mse), 1e-300):
        return "equal"
    if se is None:
        return ONE_RUN
    if se == 0.0:
        return "worse"
    z = dm / se
    if z > SEPARATED:
        return "separated"
    return "significant" if z > LEVEL else "not significant"


def rank(metric: Metric, names: Sequence[str] | None = None, reference: str | None = None
         ) -> dict[str, Any]:
    """The paired ranking of ``names`` (default: every filter of ``metric``) by the
    metric's per-run MSE (module docstring), as a ``summary.json`` block.

    Returns ``label``, ``unit``, ``runs`` (paired runs), ``best``, ``order`` and per filter
    ``rank`` (equal filters share one: :data:`IDENTICAL_RTOL`), ``rmse``, ``mse``,
    ``delta_mse``/``delta_se`` against the best (0 for the best), ``delta_percent`` (of the
    best's RMSE), ``z`` (``None`` with ``z_reason`` when the standard error is 0),
    ``better_runs`` (runs it beat the best) and ``verdict`` (``best``, ``equal`` (to
    :data:`IDENTICAL_RTOL`), ``not significant``, ``significant``, ``separated``,
    ``worse``, or with a single paired run :data:`ONE_RUN`, ``delta_se`` and ``z`` then
    ``None`` with their reasons); without a paired run only ``runs`` and a ``reason``.
    ``reference`` (e.g. the smoother, not ranked) adds its ``rmse`` over the runs it
    finished among the paired ones and the best filter's RMSE over it on those runs
    (``reference.best_over_reference``).
    """
    names = list(metric.per_run_mse) if names is None else list(names)
    out: dict[str, Any] = {"label": metric.label, "unit": metric.unit,
                           "level_se": LEVEL, "separated_se": SEPARATED}
    if not names:
        return {**out, "runs": 0, "reason": "no filter to rank"}
    M = np.vstack([np.asarray(metric.per_run_mse[n], dtype=float) for n in names])
    common = np.all(np.isfinite(M), axis=0)
    R = int(common.sum())
    out["runs"] = R
    if R < 1:
        return {**out, "reason": "no run with a score of every filter"}
    if R == 1:
        out["significance"] = ONE_RUN
    M = M[:, common]
    mean = M.mean(axis=1)
    ranks = _ranks(mean, names)
    order = sorted(range(len(names)), key=lambda i: (ranks[i], names[i]))
    b = order[0]
    out["best"] = names[b]
    out["order"] = [names[i] for i in order]
    rows: dict[str, Any] = {}
    for i in order:
        r = ranks[i]
        d = M[i] - M[b]
        dm = float(d.mean())
        se = float(d.std(ddof=1) / math.sqrt(R)) if R > 1 else None
        row: dict[str, Any] = {"rank": r, "mse": float(mean[i]), "rmse": math.sqrt(mean[i]),
                               "delta_mse": dm, "delta_se": se,
                               "delta_percent": 100.0 * (math.sqrt(mean[i] / mean[b]) - 1.0)
                               if mean[b] > 0 else 0.0,
                               "better_runs": int(np.sum(d < 0))}
        if se is None:
            row["delta_se_reason"] = row["z_reason"] = (
                f"{ONE_RUN} (a standard error needs at least 2 paired runs)")
            row["z"] = None
        elif se > 0.0:
            row["z"] = dm / se
        else:
            row["z"] = None
            row["z_reason"] = "the paired differences are all equal (standard error 0)"
        row["verdict"] = "best" if i == b else _verdict(dm, se, float(mean[b]))
        rows[names[i]] = row
    out["rows"] = rows
    if reference is not None and reference in metric.per_run_mse:
        out["reference"] = _reference(metric, reference, names[b], common)
    return out


def _reference(metric: Metric, name: str, best: str, common: Array) -> dict[str, Any]:
    ref = np.asarray(metric.per_run_mse[name], dtype=float)[common]
    best_mse = np.asarray(metric.per_run_mse[best], dtype=float)[common]
    ok = np.isfinite(ref)
    out: dict[str, Any] = {"name": name, "runs": int(ok.sum())}
    if not ok.any():
        return {**out, "rmse": None, "rmse_reason": f"{name} finished none of the paired runs"}
    r, b = float(np.mean(ref[ok])), float(np.mean(best_mse[ok]))
    out["rmse"] = math.sqrt(r)
    if r > 0:
        out["best_over_reference"] = math.sqrt(b / r)
    else:
        out["best_over_reference"] = None
        out["best_over_reference_reason"] = f"{name}'s RMSE is 0"
    return out


def rankings(metrics: Sequence[Metric], names: Sequence[str] | None = None,
             reference: str | None = None) -> dict[str, dict[str, Any]]:
    """:func:`rank` of every metric, keyed by :attr:`Metric.key`."""
    return {m.key: rank(m, names, reference) for m in metrics}


def ordering(metric: Metric, better: str, worse: str) -> dict[str, Any]:
    """The paired test of a paper's claim that filter ``better`` beats ``worse`` on
    ``metric``: :func:`paired` of their per-run MSE (``better - worse``, so a negative mean
    agrees with the claim) and a ``verdict``: ``reproduced`` (mean below −:data:`LEVEL`
    s.e.), ``reversed`` (above +:data:`LEVEL` s.e.), ``not significant``, ``equal``
    (within :data:`IDENTICAL_RTOL` of the MSE) or, with fewer than 2 paired runs, ``None``
    and a ``verdict_reason``."""
    a = np.asarray(metric.per_run_mse[better], dtype=float)
    b = np.asarray(metric.per_run_mse[worse], dtype=float)
    out: dict[str, Any] = {"metric": metric.key, "label": metric.label, "unit": metric.unit,
                           "better": better, "worse": worse, **paired(a, b)}
    ok = np.isfinite(a) & np.isfinite(b)
    if out["se"] is None:
        return {**out, "verdict": None, "verdict_reason": out["se_reason"]}
    ref = float(np.mean(b[ok]))
    out["rmse_better"], out["rmse_worse"] = math.sqrt(float(np.mean(a[ok]))), math.sqrt(ref)
    dm, se = out["mean"], out["se"]
    if abs(dm) <= IDENTICAL_RTOL * max(abs(ref), 1e-300):
        out["verdict"] = "equal"
    elif se > 0.0 and abs(dm) <= LEVEL * se:
        out["verdict"] = "not significant"
    else:
        out["verdict"] = "reproduced" if dm < 0 else "reversed"
    out["z"] = dm / se if se > 0.0 else None
    if se == 0.0:
        out["z_reason"] = "the paired differences are all equal (standard error 0)"
    return out
