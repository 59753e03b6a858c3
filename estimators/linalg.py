r"""Square-root linear algebra: triangularisation and Cholesky rank updates.

Square-root filters keep a lower-triangular factor :math:`S` of a covariance
:math:`P = S S^\top` and never form :math:`P` to factor it again.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Literal

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
    A : (n, k) array, or (..., n, k) for a batch (stacked QR, :func:`_tria_batch`)
        Any factor; ``k < n`` gives a singular (zero-padded) result.
    """
    if np.ndim(A) > 2:
        return _tria_batch(np.asarray(A, dtype=float))
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


def _tria_batch(A: Array) -> Array:
    """:func:`tria` of every matrix of a stack (..., n, k) by one stacked QR."""
    n, k = A.shape[-2:]
    R = np.linalg.qr(np.swapaxes(A, -1, -2), mode="r")  # (..., min(k, n), n)
    S = np.swapaxes(R, -1, -2)
    if S.shape[-1] < n:
        pad = np.zeros(S.shape[:-1] + (n - S.shape[-1],))
        S = np.concatenate([S, pad], axis=-1)
    d = np.diagonal(S, axis1=-2, axis2=-1)
    return S * np.where(d < 0.0, -1.0, 1.0)[..., None, :]


def swap(A: Array) -> Array:
    """The transpose of the last two axes (a batch of matrices' ``.T``)."""
    return np.swapaxes(A, -1, -2)


def outer(a: Array, b: Array) -> Array:
    """``np.outer`` of the last axes, batched: (..., n), (..., m) -> (..., n, m)."""
    if a.ndim == 1 and b.ndim == 1:
        return np.outer(a, b)
    return a[..., :, None] * b[..., None, :]


def matvec(A: Array, v: Array) -> Array:
    """``A @ v`` for a matrix and a vector, batched over leading axes of either."""
    if A.ndim == 2 and v.ndim == 1:
        return A @ v
    return (A @ v[..., None])[..., 0]


def nis_of(w: Array) -> float | Array:
    """``w · w`` of whitened innovations ``w`` (nz,) -> float, or (..., nz) -> (...,)."""
    if w.ndim == 1:
        return float(w @ w)
    return np.einsum("...i,...i->...", w, w)


def hstack(blocks: list[Array]) -> Array:
    """Matrices side by side (``np.hstack``), each broadcast to the batch shape of all."""
    if all(b.ndim == 2 for b in blocks):
        return np.hstack(blocks)
    lead = np.broadcast_shapes(*(b.shape[:-2] for b in blocks))
    return np.concatenate([np.broadcast_to(b, lead + b.shape[-2:]) for b in blocks], axis=-1)


@lru_cache(maxsize=64)
def _lower_ones(n: int, m: int) -> Array:
    mask = np.tril(np.ones((n, m)))
    mask.setflags(write=False)
    return mask


def solve_lower(L: Array, B: Array, transpose: bool = False) -> Array:
    """Solve ``L X = B`` (or ``Lᵀ X = B``) for lower-triangular ``L`` (LAPACK ``trtrs``;
    a batch ``L`` (..., n, n) with ``B`` (..., n, k) or (..., n) by a stacked solve)."""
    if np.ndim(L) > 2:
        M = swap(L) if transpose else L
        d = np.diagonal(L, axis1=-2, axis2=-1)
        if not np.all(d != 0.0):
            raise NotPositiveDefiniteError("triangular factor is singular (zero diagonal)")
        if np.ndim(B) == np.ndim(L) - 1:
            return np.linalg.solve(M, B[..., None])[..., 0]
        return np.linalg.solve(M, B)
    X, info = lapack.dtrtrs(L, B, lower=1, trans=1 if transpose else 0)
    if info != 0:
        raise NotPositiveDefiniteError(f"triangular factor is singular (LAPACK info {info})")
    return X


def kalman_gain(Pxz: Array, Szz: Array) -> Array:
    r""":math:`K = P_{xz} (S_{zz} S_{zz}^\top)^{-1}` with two triangular solves (no inverse);
    batched over leading axes."""
    return swap(solve_lower(Szz, solve_lower(Szz, swap(Pxz)), transpose=True))


def qr_complete(M: Array) -> tuple[Array, Array]:
    r"""Complete QR of a tall ``M`` (m, k): :math:`M = Q\,[R;\ 0]` with the full orthogonal
    :math:`Q` (m, m) and the upper-triangular :math:`R` (k, k) with a non-negative
    diagonal (LAPACK ``geqrf``/``orgqr``; the first ``k`` columns of :math:`Q` are
    sign-fixed with :math:`R`)."""
    m, k = M.shape
    qr, tau, _, info = lapack.dgeqrf(np.array(M, order="F"))
    if info != 0:
        raise np.linalg.LinAlgError(f"QR failed (LAPACK info {info})")
    R = np.triu(qr[:k])
    A = np.zeros((m, m), order="F")
    A[:, :k] = qr
    Q, _, info = lapack.dorgqr(A, np.concatenate([tau, np.zeros(m - len(tau))]))
    if info != 0:
        raise np.linalg.LinAlgError(f"QR failed (LAPACK info {info})")
    d = np.where(np.diagonal(R) < 0.0, -1.0, 1.0)
    Q[:, :k] *= d
    return Q, R * d[:, None]


def chol(P: Array) -> Array:
    """Lower Cholesky factor of ``P``; raises :class:`NotPositiveDefiniteError`."""
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError as exc:
        raise NotPositiveDefiniteError(f"covariance is not positive definite: {exc}") from exc


def chol_update(S: Array, V: Array, sign: float = 1.0, *,
                method: Literal["qr", "sweep"] = "qr") -> Array:
    r"""Rank-k Cholesky update or downdate.

    Returns the lower factor :math:`S'` with

    .. math::  S' S'^\top = S S^\top + \mathrm{sign} \cdot V V^\top .

    Parameters
    ----------
    S : (n, n) array, lower triangular with positive diagonal (not modified).
    V : (n,) or (n, k) array.
    sign : +1 (update) or -1 (downdate).
    method : ``"qr"`` (default) updates by a triangularisation ``tria([S, V])``
        (:math:`O(n^3)`) and downdates vector by vector, element by element;
        ``"sweep"`` (:func:`chol_update_sweep`, for large ``n``) updates in
        :math:`O(k n^2)` by a Householder row sweep and downdates by a blocked
        hyperbolic row sweep.  The two agree to rounding.

    Raises
    ------
    NotPositiveDefiniteError
        If a downdate would make the matrix indefinite.
    """
    if np.ndim(S) > 2:
        return _chol_update_batch(np.asarray(S, dtype=float), np.asarray(V, dtype=float), sign)
    V = np.asarray(V, dtype=float).reshape(S.shape[0], -1)
    if method == "sweep":
        return chol_update_sweep(S, V, sign)
    if method != "qr":
        raise ValueError(f"unknown chol_update method {method!r}")
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


def _chol_update_batch(S: Array, V: Array, sign: float) -> Array:
    """:func:`chol_update` (``"qr"``) of a stack: ``S`` (..., n, n), ``V`` (..., n) or
    (..., n, k); the downdate's row loop runs once for the whole stack (one failing
    member raises for all: the batched filter loop then finds it, :mod:`estimators.batch`)."""
    n = S.shape[-1]
    if V.ndim == S.ndim - 1:
        V = V[..., None]
    V = np.broadcast_to(V, S.shape[:-2] + V.shape[-2:])
    if sign > 0:
        return tria(np.concatenate([S, V], axis=-1))
    L = np.array(S, dtype=float, copy=True)
    V = np.array(V, dtype=float, copy=True)
    for j in range(V.shape[-1]):
        x = V[..., j]
        for k in range(n):
            lkk = L[..., k, k]
            r2 = lkk * lkk - x[..., k] * x[..., k]
            if not np.all((r2 > 0.0) & (lkk > 0.0)):
                raise NotPositiveDefiniteError(
                    f"Cholesky downdate lost positive definiteness at row {k}")
            r = np.sqrt(r2)
            c = (r / lkk)[..., None]
            sk = (x[..., k] / lkk)[..., None]
            L[..., k, k] = r
            if k + 1 < n:
                col = (L[..., k + 1:, k] - sk * x[..., k + 1:]) / c
                x[..., k + 1:] = c * x[..., k + 1:] - sk * col
                L[..., k + 1:, k] = col
    return L


#: Rows per block of the blocked downdate sweep.
SWEEP_BLOCK = 64


def chol_update_sweep(S: Array, V: Array, sign: float = 1.0, block: int = SWEEP_BLOCK
                      ) -> Array:
    r"""Rank-k Cholesky update (``sign > 0``) or downdate by one sweep down the rows.

    Each step touches only the trailing rows; neither forms :math:`S S^\top`.

    Update
        :math:`[S,\ V]\,Q = [S',\ 0]`: the QR factorisation of the
        triangular-pentagonal matrix :math:`[S^\top;\ V^\top]` (LAPACK ``dtpqrt``):
        for each row :math:`j` a Householder reflection folds :math:`V_{j,:}` into
        :math:`S_{jj}` and is applied to the trailing rows :math:`[S_{j+1:,j},\
        V_{j+1:,:}]`: :math:`O(k n^2)`, compiled.  Exact and never fails; a singular
        :math:`S` is fine.

    Downdate
        A blocked hyperbolic sweep.  For a block :math:`J` of ``block`` rows and the
        trailing rows :math:`T`, with :math:`A = S_{JJ}^{-1} V_J`,
        :math:`\Lambda\Lambda^\top = I - AA^\top` and :math:`RR^\top = I - A^\top A`
        (Cholesky):

        .. math::

            S'_{JJ} = S_{JJ}\Lambda,\quad
            S'_{TJ} = (S_{TJ} - V_T A^\top)\,\Lambda^{-\top},\quad
            V'_T = V_T R - S'_{TJ}\,\Lambda^\top A R^{-\top},

        and the sweep goes on with :math:`V'_T` on :math:`S_{TT}`.  (The transformation
        taking :math:`[S_{JJ}, V_J]` to :math:`[S'_{JJ}, 0]` is J-orthogonal; the last
        formula is the mixed, stable form of hyperbolic rotations, which it is for
        ``block = 1``.)  :math:`O(b\,n^2)` flops for blocks of ``b`` rows, but only
        ``n / b`` Python steps.  Raises :class:`NotPositiveDefiniteError` if
        :math:`S S^\top - VV^\top` is not positive definite (or a diagonal block of
        :math:`S` is singular); see :func:`chol_update_mixed` for both signs at once.
    """
    S = np.asarray(S, dtype=float)
    n = S.shape[0]
    V = np.asarray(V, dtype=float).reshape(n, -1)
    k = V.shape[1]
    if n == 0 or k == 0:
        return np.array(S, dtype=float, copy=True)
    if sign > 0:
        A = np.array(S.T, dtype=float, order="F", copy=True)   # upper triangular Sᵀ
        B = np.array(V.T, dtype=float, order="F", copy=True)
        R, _, _, info = lapack.dtpqrt(0, max(1, min(16, n)), A, B, overwrite_a=1,
                                      overwrite_b=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"triangular-pentagonal QR failed (info {info})")
        neg = np.flatnonzero(np.diagonal(R) < 0.0)   # R's strict lower part stays zero
        if neg.size:
            R[neg] *= -1.0
        return R.T
    return chol_update_mixed(S, np.zeros((n, 0)), V, block)


def chol_update_mixed(S: Array, Vp: Array, Vn: Array, block: int = SWEEP_BLOCK) -> Array:
    r"""Lower factor :math:`S'` of :math:`SS^\top + V_pV_p^\top - V_nV_n^\top` in one sweep.

    The blocked hyperbolic sweep of :func:`chol_update_sweep` with columns of both signs,
    :math:`V = [V_p, V_n]`, :math:`J = \mathrm{diag}(I_p, -I_k)`.  For a block :math:`J`
    of rows and the trailing rows :math:`T`, with :math:`A = S_{JJ}^{-1} V_J`:

    .. math::

        \Lambda\Lambda^\top = I + AJA^\top,\quad
        S'_{JJ} = S_{JJ}\Lambda,\quad
        S'_{TJ} = (S_{TJ} + V_T J A^\top)\,\Lambda^{-\top},\quad
        V'_T = V_T J R J - S'_{TJ}\,\Lambda^\top A R^{-\top},

    where :math:`RJR^\top = A^\top A + J` (a block J-Cholesky factorisation:
    :math:`R_{11} = \mathrm{chol}(I + A_p^\top A_p)`,
    :math:`R_{21} = A_n^\top A_p R_{11}^{-\top}`,
    :math:`R_{22} = \mathrm{chol}(I - A_n^\top A_n + R_{21}R_{21}^\top)`).  The map
    :math:`[S_{JJ}, V_J] \to [S'_{JJ}, 0]` is J-orthogonal, so
    :math:`S'_{TT}` continues the sweep with :math:`V'_T` and the same signature.  Needs
    non-singular diagonal blocks of :math:`S`; raises :class:`NotPositiveDefiniteError` if
    a block is singular or the result is not positive definite.  Used to fold a pending
    positive update into a measurement downdate (:mod:`estimators.partitioned`).
    """
    S = np.asarray(S, dtype=float)
    n = S.shape[0]
    Vp = np.asarray(Vp, dtype=float).reshape(n, -1)
    Vn = np.asarray(Vn, dtype=float).reshape(n, -1)
    p, k = Vp.shape[1], Vn.shape[1]
    L = np.array(S, dtype=float, copy=True)
    if n == 0 or p + k == 0:
        return L
    X = np.hstack([Vp, Vn])
    Jd = np.concatenate([np.ones(p), -np.ones(k)])
    for j in range(0, n, block):
        e = min(j + block, n)
        Ljj = L[j:e, j:e]
        A = solve_lower(Ljj, X[j:e])
        Lam = _chol_or_raise((A * Jd) @ A.T, j)
        R = _j_cholesky(A, p, j)
        L[j:e, j:e] = Ljj @ Lam
        if e < n:
            XJ = X[e:] * Jd
            Lt = L[e:, j:e] + XJ @ A.T
            Lt = solve_lower(Lam, Lt.T).T                        # · Λ^{-T}
            Gam = solve_lower(R, (Lam.T @ A).T).T                # Λᵀ A R^{-T}
            X[e:] = (XJ @ R) * Jd - Lt @ Gam
            L[e:, j:e] = Lt
    return L


def _j_cholesky(A: Array, p: int, row: int) -> Array:
    """Lower ``R`` with ``R J Rᵀ = AᵀA + J``, ``J = diag(I_p, -I_k)``."""
    AtA = A.T @ A
    m = AtA.shape[0]
    R = np.zeros((m, m))
    if p:
        R11 = _chol_or_raise(AtA[:p, :p].copy(), row)
        R[:p, :p] = R11
        if m > p:
            R21 = solve_lower(R11, AtA[:p, p:]).T
            R[p:, :p] = R21
            R[p:, p:] = _chol_or_raise(R21 @ R21.T - AtA[p:, p:], row)
    else:
        R[:, :] = _chol_or_raise(-AtA, row)
    return R


def _chol_or_raise(M: Array, row: int) -> Array:
    """Lower Cholesky factor of ``I + M`` (``M`` symmetric, overwritten)."""
    M.flat[:: M.shape[0] + 1] += 1.0
    c, info = lapack.dpotrf(M, lower=1, clean=1, overwrite_a=1)
    if info != 0:
        raise NotPositiveDefiniteError(
            f"Cholesky downdate lost positive definiteness in the block at row {row}")
    return c


def svd_factor(A: Array) -> Array:
    r"""Square factor :math:`U \Sigma` (n, n) with :math:`(U\Sigma)(U\Sigma)^\top = A A^\top`.

    From the thin SVD :math:`A = U \Sigma V^\top` (the SVD-CKF's factorisation); batched
    over leading axes.
    """
    n, k = A.shape[-2:]
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    F = U * s[..., None, :]
    if F.shape[-1] < n:
        F = np.concatenate([F, np.zeros(F.shape[:-1] + (n - F.shape[-1],))], axis=-1)
    return F


def block_diag2(A: Array, B: Array) -> Array:
    """Block-diagonal ``[[A, 0], [0, B]]`` for two square blocks (either may carry leading
    batch axes; the other is broadcast)."""
    n, m = A.shape[-1], B.shape[-1]
    lead = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    out = np.zeros(lead + (n + m, n + m))
    out[..., :n, :n] = A
    out[..., n:, n:] = B
    return out
