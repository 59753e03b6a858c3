r"""Filter consistency: NEES, NIS and their χ² bands (Bar-Shalom, Li & Kirubarajan 2001, §5.4).

For an estimate :math:`\hat x_k` with covariance :math:`P_k` of a state :math:`x_k` the
normalised estimation error squared is :math:`\epsilon_k = e_k^\top P_k^{-1} e_k`,
:math:`e_k = x_k - \hat x_k`; for an innovation :math:`\nu_k` with covariance :math:`S_k`
the normalised innovation squared is :math:`\nu_k^\top S_k^{-1} \nu_k`.  For a consistent
filter both are :math:`\chi^2_n` distributed (``n`` the dimension), so the average over
:math:`R` independent runs divided by ``n`` is :math:`\chi^2_{nR}/(nR)`; its two-sided
band at level ``q`` is :math:`[\chi^2_{nR}((1-q)/2),\ \chi^2_{nR}((1+q)/2)]/(nR)`.
The ANEES is the time average of the run-averaged NEES / n; the per-epoch in-band share is
the fraction of epochs whose run average lies inside the band.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gammaincinv

Array = NDArray[np.float64]
COND_LIMIT = 1e12  # covariances more ill-conditioned than this get no NEES

__all__ = ["COND_LIMIT", "nees", "nis", "nees_series", "chi2_ppf", "chi2_band", "anees_band",
           "per_epoch_anees", "anees_stats", "nis_stats"]


def nees_series(err: ArrayLike, cov: ArrayLike) -> Array:
    r""":math:`e_k^\top P_k^{-1} e_k` per step for errors ``err`` (E, n) and covariances
    ``cov`` (E, n, n); NaN where ``cov`` is non-finite or has condition number above
    :data:`COND_LIMIT` (singular, indefinite) or the error is not finite."""
    err = np.asarray(err, dtype=float)
    cov = np.asarray(cov, dtype=float)
    out = np.full(err.shape[0], np.nan)
    ok = np.all(np.isfinite(cov), axis=(1, 2)) & np.all(np.isfinite(err), axis=1)
    if ok.any() and err.shape[1] == 2:
        _nees_2d(err, cov, ok, out)
    elif ok.any():
        w = np.linalg.eigvalsh(cov[ok])
        good = w[:, 0] > w[:, -1] / COND_LIMIT
        idx = np.flatnonzero(ok)[good]
        e = err[idx]
        out[idx] = np.einsum("ki,ki->k", e, np.linalg.solve(cov[idx], e[..., None])[..., 0])
    return out


def _nees_2d(err: Array, cov: Array, ok: NDArray[np.bool_], out: Array) -> None:
    """:func:`nees_series` for 2-D errors in closed form (:func:`nees_2d_entries`)."""
    e, P = err[ok], cov[ok]
    out[np.flatnonzero(ok)] = nees_2d_entries(e[:, 0], e[:, 1], P[:, 0, 0],
                                              0.5 * (P[:, 0, 1] + P[:, 1, 0]), P[:, 1, 1])


def nees_2d_entries(e0: Array, e1: Array, a: Array, b: Array, c: Array) -> Array:
    r"""2-D NEES from the entries (any shape, elementwise) of errors :math:`(e_0, e_1)` and
    covariances :math:`P = [[a, b], [b, c]]` in closed form (no LAPACK call per step):
    eigenvalues :math:`m \pm \sqrt{d^2 + b^2}` with :math:`m, d = (a \pm c)/2` and
    :math:`e^\top P^{-1} e = (c e_0^2 - 2 b e_0 e_1 + a e_1^2)/(ac - b^2)`; NaN where the
    condition number is above :data:`COND_LIMIT` (finite entries expected)."""
    m, r = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    good = m - r > (m + r) / COND_LIMIT
    det = np.where(good, a * c - b * b, 1.0)
    val = (c * e0 ** 2 - 2.0 * b * e0 * e1 + a * e1 ** 2) / det
    return np.where(good, val, np.nan)


def nees(err: ArrayLike, cov: ArrayLike) -> Array:
    """NEES of errors (E, n) with covariances (E, n, n), or of one error (n,) with (n, n)
    (a 0-d array); NaN where not computable (:func:`nees_series`)."""
    err = np.asarray(err, dtype=float)
    if err.ndim == 1:
        return nees_series(err[None], np.asarray(cov, dtype=float)[None])[0]
    return nees_series(err, cov)


def nis(innovation: ArrayLike, cov: ArrayLike) -> Array:
    r"""NIS :math:`\nu^\top S^{-1}\nu` of innovations (E, m) with their covariances
    (E, m, m) (or one (m,) with (m, m)): the NEES of the innovation."""
    return nees(innovation, cov)


def chi2_ppf(q: ArrayLike, dof: ArrayLike) -> Array:
    r"""The χ² quantile, :math:`2\,P^{-1}(\nu/2, q)` (regularised incomplete gamma): what
    ``scipy.stats.chi2.ppf`` evaluates, without importing ``scipy.stats`` (a second of
    start-up)."""
    return 2.0 * gammaincinv(np.asarray(dof, dtype=float) / 2.0, q)


def chi2_band(dof: ArrayLike, level: float = 0.95) -> tuple[Array, Array]:
    """Two-sided ``level`` band of one χ²(``dof``) value (per element of ``dof``)."""
    a = (1.0 - level) / 2.0
    return chi2_ppf(a, dof), chi2_ppf(1.0 - a, dof)


def anees_band(runs: int, dof: int = 3, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` band of the average over ``runs`` of a χ²(``dof``) NEES divided
    by ``dof``: χ²_{runs·dof} quantiles / (runs·dof)."""
    n = runs * dof
    lo, hi = chi2_band(n, level)
    return float(lo / n), float(hi / n)


def per_epoch_anees(nees: ArrayLike, dof: int) -> Array:
    """Run-averaged NEES per epoch divided by ``dof`` from per-run series ``nees`` (R, E);
    NaN at epochs where no run has a NEES."""
    nees = np.asarray(nees, dtype=float)
    finite = np.isfinite(nees)
    count = finite.sum(axis=0)
    return np.where(count > 0, np.where(finite, nees, 0.0).sum(axis=0)
                    / np.maximum(count, 1), np.nan) / dof


def anees_stats(nees: ArrayLike, dof: int, level: float = 0.95) -> dict[str, Any]:
    """ANEES of per-run NEES series ``nees`` (R, E) with its two-sided band (for R runs),
    the fractions of epochs whose run-averaged NEES / dof lies inside the band
    (``inside``, the in-band share) and above it, and the distance of the ANEES to the
    band (0 inside); ``{}`` when there is no NEES."""
    nees = np.asarray(nees, dtype=float)
    per_step = per_epoch_anees(nees, dof)
    valid = per_step[np.isfinite(per_step)]
    if not valid.size:
        return {}
    lo, hi = anees_band(nees.shape[0], dof, level)
    value = float(valid.mean())
    distance = 0.0 if lo <= value <= hi else float(min(abs(value - lo), abs(value - hi)))
    return {"value": value, "band": [lo, hi],
            "inside": float(np.mean((valid >= lo) & (valid <= hi))),
            "above": float(np.mean(valid > hi)), "distance": distance}


def nis_stats(nis: ArrayLike, dof: ArrayLike, level: float = 0.95) -> dict[str, Any]:
    r"""Consistency of single updates' NIS ``nis`` (N,) of dimensions ``dof`` (N,) (NaN
    entries left out): ``per_dof`` :math:`\sum_i \nu_i / \sum_i d_i` with its exact band
    (:math:`\chi^2_{\sum d}/\sum d`, the updates independent), ``mean`` (the mean of
    :math:`\nu_i/d_i`), and the share of updates inside their own χ²(d_i) band
    (``inside``, expected ``level``) and above it; ``{}`` when there is no NIS."""
    v = np.asarray(nis, dtype=float).ravel()
    d = np.broadcast_to(np.asarray(dof, dtype=float), v.shape)
    ok = np.isfinite(v) & (d > 0)
    if not ok.any():
        return {}
    v, d = v[ok], d[ok]
    total = float(d.sum())
    lo, hi = chi2_band(total, level)
    each_lo, each_hi = chi2_band(d, level)
    return {"per_dof": float(v.sum() / total), "band": [float(lo / total), float(hi / total)],
            "mean": float(np.mean(v / d)), "updates": int(v.size),
            "inside": float(np.mean((v >= each_lo) & (v <= each_hi))),
            "above": float(np.mean(v > each_hi))}
