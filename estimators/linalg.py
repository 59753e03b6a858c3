r"""Square-root linear algebra: triangularisation and Cholesky rank updates.

Square-root filters keep a lower-triangular factor :math:`S` of a covariance
:math:`P = S S^\top` and never form :math:`P` to factor it again.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

Array = NDArray[np.float64]


class NotPositiveDefiniteError(np.linalg.LinAlgError):
    """A covariance (or a factor update) stopped being positive definite."""


def tria(A: Array) -> Array:
    r"""Lower-triangular :math:`S` (n, n) with :math:`S S^\top = A A^\top` and :math:`S_{ii} \ge 0`.

    From the QR decomposition :math:`A^\top = Q R`: :math:`A A^\top = R^\top R`, so
    :math:`S = R^\top` up to column signs.

    Parameters
    ----------
    A : (n, k) array
        Any factor; ``k < n`` gives a singular (zero-padded) result.
    """
    n, k = A.shape
    qr, _, _, info = lapack.dgeqrf(np.asarray(A, dtype=float).T)
    if info != 0:
        raise np.linalg.LinAlgError(f"QR failed (LAPACK info {info})")
    S = qr[: min(k, n)].T * _lower_ones(n, min(k, n))
    if S.shape[1] < n:
        S = np.hstack([S, np.zeros((n, n - S.shape[1]))])
    d = np.diagonal(S)
    if (d < 0.0).any():
        S = S * np.where(d < 0.0, -1.0, 1.0)
    return S


@lru_cache(maxsize=64)
def _lower_ones(n: int, m: int) -> Array:
    mask = np.tril(np.ones((n, m)))
    mask.setflags(write=False)
    return mask


def solve_lower(L: Array, B: Array, transpose: bool = False) -> Array:
    """Solve ``L X = B`` (or ``Lᵀ X = B``) for lower-triangular ``L`` (LAPACK ``trtrs``)."""
    X, info = lapack.dtrtrs(L, B, lower=1, trans=1 if transpose else 0)
    if info != 0:
        raise NotPositiveDefiniteError(f"triangular factor is singular (LAPACK info {info})")
    return X


def chol(P: Array) -> Array:
    """Lower Cholesky factor of ``P``; raises :class:`NotPositiveDefiniteError`."""
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError as exc:
        raise NotPositiveDefiniteError(f"covariance is not positive definite: {exc}") from exc


def chol_update(S: Array, V: Array, sign: float = 1.0) -> Array:
    r"""Rank-k Cholesky update or downdate.

    Returns the lower factor :math:`S'` with

    .. math::  S' S'^\top = S S^\top + \mathrm{sign} \cdot V V^\top .

    Parameters
    ----------
    S : (n, n) array, lower triangular with positive diagonal (not modified).
    V : (n,) or (n, k) array.
    sign : +1 (update) or -1 (downdate).

    Raises
    ------
    NotPositiveDefiniteError
        If a downdate would make the matrix indefinite.
    """
    V = np.asarray(V, dtype=float).reshape(S.shape[0], -1)
    if sign > 0:  # an update is a triangularisation of [S, V]; exact and never fails
        return tria(np.hstack([S, V]))
    L = np.array(S, dtype=float, copy=True)
    V = V.copy()
    n = L.shape[0]
    for j in range(V.shape[1]):
        x = V[:, j]
        for k in range(n):
            lkk = L[k, k]
            r2 = lkk * lkk - x[k] * x[k]
            if not (r2 > 0.0 and lkk > 0.0):
                raise NotPositiveDefiniteError(
                    f"Cholesky downdate lost positive definiteness at row {k}")
            r = np.sqrt(r2)
            c = r / lkk
            s = x[k] / lkk
            L[k, k] = r
            if k + 1 < n:
                col = (L[k + 1:, k] - s * x[k + 1:]) / c
                x[k + 1:] = c * x[k + 1:] - s * col
                L[k + 1:, k] = col
    return L


def svd_factor(A: Array) -> Array:
    r"""Square factor :math:`U \Sigma` (n, n) with :math:`(U\Sigma)(U\Sigma)^\top = A A^\top`.

    From the thin SVD :math:`A = U \Sigma V^\top` (the SVD-CKF's factorisation).
    """
    n, k = A.shape
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    F = U * s
    if F.shape[1] < n:
        F = np.hstack([F, np.zeros((n, n - F.shape[1]))])
    return F


def block_diag2(A: Array, B: Array) -> Array:
    """Block-diagonal ``[[A, 0], [0, B]]`` for two square blocks."""
    n, m = A.shape[0], B.shape[0]
    out = np.zeros((n + m, n + m))
    out[:n, :n] = A
    out[n:, n:] = B
    return out
