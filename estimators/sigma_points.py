r"""Sigma points and covariance factors: drawing a rule's points from a belief (with any
non-additive noise appended) and turning a rule's factor into the dense, square-root or
SVD form.  Shared by the sigma-point filters' own steps and their partitioned steps."""

from __future__ import annotations

from typing import Literal

import numpy as np

from .linalg import (
    Array,
    NotPositiveDefiniteError,
    block_diag2,
    chol,
    chol_update,
    hstack,
    outer,
    svd_factor,
    swap,
    tria,
)
from .models import Belief, Noise, SqrtGaussian
from .rules import Factor, PointRule

Form = Literal["dense", "sqrt", "svd"]


SqrtMethod = Literal["cholesky", "eigh"]


def factor_of(belief: Belief, method: SqrtMethod = "cholesky") -> Array:
    r"""A square factor of the belief's covariance.

    A square-root belief gives its stored factor.  A dense belief is factored by
    Cholesky, or by the eigen-decomposition :math:`P = U\Lambda U^\top \to U\Lambda^{1/2}`
    (``"eigh"``: the points the SVD-factored filter draws, up to order and sign).  A
    singular but positive semi-definite covariance (a state known exactly in some
    directions, e.g. a zero initial vehicle covariance) has no Cholesky factor; it is
    factored by :func:`psd_factor`, as the square-root forms carry it.
    """
    if isinstance(belief, SqrtGaussian):
        return belief.sqrt
    if method == "cholesky":
        try:
            return chol(belief.cov)
        except NotPositiveDefiniteError:
            return psd_factor(belief.cov)
    lam, U = np.linalg.eigh(belief.cov)
    if not lam.min() > 0.0:
        return psd_factor(belief.cov)
    return U * np.sqrt(lam)[..., None, :]


def psd_factor(P: Array) -> Array:
    r"""A square factor :math:`U\Lambda_+^{1/2}` of a positive semi-definite ``P``
    (eigenvalues down to :math:`-n\,\epsilon\,\lambda_{max}` count as zero); raises
    :class:`NotPositiveDefiniteError` for a covariance with a clearly negative or a
    non-finite eigenvalue."""
    lam, U = np.linalg.eigh(0.5 * (P + swap(P)))
    top = np.max(np.abs(lam), axis=-1, initial=0.0)
    tol = P.shape[-1] * np.finfo(float).eps * top
    if not (np.all(np.isfinite(top)) and np.all(lam.min(axis=-1, initial=0.0) >= -tol)):
        raise NotPositiveDefiniteError(f"covariance has eigenvalue {lam.min():.3e} < 0")
    return U * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]


def prior_factor(P: Array) -> Array:
    """Lower-triangular factor of a prior covariance ``P``: its Cholesky factor, or for a
    positive semi-definite (singular) prior, e.g. a state known exactly, the
    triangularised :func:`psd_factor`; a clearly negative eigenvalue still raises."""
    try:
        return chol(P)
    except NotPositiveDefiniteError:
        return tria(psd_factor(P))


def draw(rule: PointRule, belief: Belief, noise: Noise | None = None,
         method: SqrtMethod = "cholesky") -> tuple[Array, Array, Array, Array]:
    """Sigma points of ``belief`` (optionally jointly with an independent noise input).

    Returns
    -------
    X : (..., m, nx) points on the belief's space (leading axes: a batch of beliefs).
    W : (..., m, nw) noise points (``nw = 0`` without noise).
    dX : (..., m, d) tangent deviations :math:`S\\xi_i` of the state part.
    wm : (m,) mean weights.
    """
    S = factor_of(belief, method)
    if noise is not None:
        S = block_diag2(S, noise.sqrt)
    xi, wm = rule.points(S.shape[-1])
    delta = xi @ swap(S)
    d = belief.dim
    X = belief.space.retract(belief.mean[..., None, :], delta[..., :d])
    return X, delta[..., d:], delta[..., :d], wm


def dense_cov(fac: Factor, noise_cov: Array | None) -> Array:
    """``C Cᵀ + sign·c0 c0ᵀ (+ noise_cov)``, symmetrised (batched over leading axes)."""
    P = fac.C @ swap(fac.C)
    if noise_cov is not None:
        P = P + noise_cov
    if fac.c0 is not None:
        P = P + fac.sign * outer(fac.c0, fac.c0)
    return 0.5 * (P + swap(P))


def factorise(form: Form, fac: Factor, extra: Array | None) -> Array:
    """Square factor of ``[C, extra][C, extra]ᵀ + sign·c0 c0ᵀ`` by QR (``sqrt``: ``tria``
    then a signed rank-one Cholesky update) or SVD (``svd``)."""
    blocks = [fac.C] if extra is None else [fac.C, extra]
    if form == "svd":
        if fac.c0 is not None:
            if fac.sign < 0:
                raise ValueError("the SVD form needs non-negative weights")
            blocks.append(fac.c0[..., None])
        return svd_factor(hstack(blocks))
    S = tria(hstack(blocks))
    if fac.c0 is not None:
        S = chol_update(S, fac.c0, fac.sign)
    return S
