r"""Quaternion pseudo-observations of vector measurements, [Ding 2017] eq. (7)-(9), (15)-(16).

Convention check
----------------
The paper writes :math:`\bar B_j = C(q) R_j + \mu_j` with :math:`C(q)` mapping the
reference (navigation) frame into the body frame.  Here ``q`` is ``q_nb`` (body →
navigation, :func:`nav.quaternion.qto_dcm` gives :math:`C_{nb}`), so the same model reads

.. math::

    \bar B = C(q)^\top R + \mu \iff R = C(q)\,(\bar B - \mu),

with :math:`B` the body-frame measurement of the known navigation-frame reference
:math:`R`, :math:`\mu \sim N(0, \Sigma_B)`.

Pseudo-observation (eq. 8)
--------------------------
:math:`R = C(q) B` is :math:`q \otimes [0, B] \otimes q^* = [0, R]`, i.e.
:math:`q \otimes [0, B] - [0, R] \otimes q = 0`, which is *linear* in :math:`q`.  With
scalar-first :math:`q = [q_0, q_v]`,

.. math::

    G(B, R) = \tfrac12 \begin{bmatrix} 0 & -(B - R)^\top \\
                                       B - R & -[(B + R)\times] \end{bmatrix},
    \qquad G(B, R)\, q = \tfrac12\big(q \otimes [0, B] - [0, R] \otimes q\big) = 0

for the true attitude (the paper's :math:`G_j`, with its scalar-last rows and columns
moved to scalar-first; the factor :math:`\tfrac12` is the paper's).  :math:`G` is
skew-symmetric, so :math:`q^\top G q \equiv 0`, and it has rank 2 (one vector fixes the
attitude up to a rotation about :math:`R`).  With the noisy :math:`\bar B = B + \mu`,

.. math::

    G(\bar B, R)\, q = \tfrac12\, q \otimes [0, \mu] = \tfrac12\, \Xi(q)\,\mu ,\qquad
    \Xi(q) = \begin{bmatrix} -q_v^\top \\ q_0 I + [q_v\times]\end{bmatrix},

so the measurement is :math:`z = 0 = h(q) + v` with :math:`h(q) = G(\bar B, R)\,q` and the
state-dependent noise :math:`v = -\tfrac12 \Xi(q)\mu` (eq. 8: the paper's
:math:`M(q)` is :math:`\Xi(q)`).

Noise separation (eq. 15-16)
----------------------------
:math:`v = \sum_i \mu_i A_i q` with constant :math:`A_i = -\tfrac12\,\Xi(\cdot)e_i`
(the matrix of :math:`q \mapsto -\tfrac12 q \otimes [0, e_i]`), the form
:math:`Z = G_e(X) w` of eq. (10).  With :math:`\mu` independent of :math:`q`, mean
:math:`\hat\mu` and covariance :math:`P_\mu`, and :math:`q` of ambient mean :math:`\hat X`
and covariance :math:`P_X`,

.. math::

    P_v = G_e\big[(P_\mu + \hat\mu\hat\mu^\top) \otimes P_X\big] G_e^\top
          + G(\hat X)\, P_\mu\, G(\hat X)^\top ,\qquad
    G_e = [A_1\ A_2\ A_3],\quad G(\hat X) = [A_1\hat X\ A_2\hat X\ A_3\hat X]
        = -\tfrac12\Xi(\hat X),

(eq. 15; eq. 16 is :math:`\hat\mu = 0`).  It is exact for any distribution of :math:`q`
given its first two ambient moments.

In a filter
-----------
The noise depends on the attitude, but a :class:`~estimators.models.Measurement` carries
a fixed noise.  :func:`pseudo_observation_model` therefore evaluates it at the *prior*
(predicted) belief: :math:`\hat X = \hat q` and, from the tangent covariance
:math:`P_\delta` of the right perturbation :math:`q = \hat q \otimes \mathrm{Exp}(\delta)`,
the first-order ambient covariance :math:`P_X = \tfrac14 \Xi(\hat q) P_\delta
\Xi(\hat q)^\top`.  Build a new model for every update, from the belief that update
receives, and call the filter with ``z = 0``.

The 4-vector :math:`G q` has (for the same :math:`q`) no component along :math:`q`, so its
noise covariance is singular along :math:`\hat q`.  By default (``project=True``) each
pseudo-observation is projected onto :math:`\hat q^\perp` with the orthonormal
:math:`T = \Xi(\hat q)^\top` (3x4): :math:`z_j = T G_j q` with noise :math:`T P_v T^\top`
(positive definite); the dropped component is second order in the attitude error.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators.models import Measurement, Noise

from .quaternion import skew

Array = NDArray[np.float64]

__all__ = [
    "pseudo_observation_matrix",
    "pseudo_observation_model",
    "pseudo_observation_noise",
    "xi_matrix",
]


def xi_matrix(q: ArrayLike) -> Array:
    r""":math:`\Xi(q)` (4x3) with :math:`q \otimes [0, v] = \Xi(q)\, v`.

    For unit ``q`` its columns are orthonormal and orthogonal to ``q``:
    :math:`\Xi^\top\Xi = I_3`, :math:`\Xi\Xi^\top = I_4 - q q^\top`.

    Shapes: ``q`` (..., 4) → (..., 4, 3).
    """
    q = np.asarray(q, dtype=np.float64)
    top = -q[..., None, 1:]
    bottom = q[..., 0, None, None] * np.eye(3) + skew(q[..., 1:])
    return np.concatenate([top, bottom], axis=-2)


def pseudo_observation_matrix(B: ArrayLike, R_ref: ArrayLike) -> Array:
    r""":math:`G(B, R)` (4x4) with :math:`G q = \tfrac12(q \otimes [0,B] - [0,R] \otimes q)`.

    Parameters
    ----------
    B : array_like, shape (..., 3)
        Body-frame vector measurement.
    R_ref : array_like, shape (..., 3)
        The same vector in the navigation frame (broadcast against ``B``).

    Returns
    -------
    ndarray, shape (..., 4, 4)
        Zero on the true ``q_nb`` when ``B = C(q_nb)ᵀ R_ref`` exactly.
    """
    B, R = np.broadcast_arrays(np.asarray(B, dtype=np.float64),
                               np.asarray(R_ref, dtype=np.float64))
    d, s = B - R, B + R
    top = np.concatenate([np.zeros(d.shape[:-1] + (1, 1)), -d[..., None, :]], axis=-1)
    bottom = np.concatenate([d[..., :, None], -skew(s)], axis=-1)
    return 0.5 * np.concatenate([top, bottom], axis=-2)


def _cov3(sigma: ArrayLike) -> Array:
    s = np.asarray(sigma, dtype=np.float64)
    if s.ndim == 0:
        return float(s) ** 2 * np.eye(3)
    if s.shape == (3,):
        return np.diag(s**2)
    if s.shape == (3, 3):
        return s
    raise ValueError(f"sigma must be a scalar, 3 standard deviations or a 3x3 covariance, "
                     f"got shape {s.shape}")


def pseudo_observation_noise(q_mean: ArrayLike, q_cov: ArrayLike | None, sigma: ArrayLike,
                             mu_mean: ArrayLike | None = None) -> Array:
    r"""Covariance of :math:`v = -\tfrac12 q \otimes [0, \mu]` by the noise-separation formula.

    Parameters
    ----------
    q_mean : array_like, shape (4,)
        Ambient mean :math:`\hat X` of the attitude quaternion (need not be unit).
    q_cov : array_like, shape (4, 4), or None
        Ambient covariance :math:`P_X` (``None``: a known attitude, :math:`P_X = 0`).
    sigma : float, (3,) or (3, 3)
        Measurement noise: a standard deviation, per-axis standard deviations, or the
        covariance :math:`P_\mu`.
    mu_mean : array_like, shape (3,), optional
        Noise mean :math:`\hat\mu` (eq. 15); zero gives eq. 16.

    Returns
    -------
    ndarray, shape (4, 4)
    """
    Pmu = _cov3(sigma)
    x = np.asarray(q_mean, dtype=np.float64)
    A = -0.5 * xi_matrix(np.eye(4))  # A[j] = Ξ(e_j): Ξ(q) = Σ_j q_j Ξ(e_j)
    # A_i (4x4) maps q to -½ q ⊗ [0, e_i]:  column j of A_i is -½ Ξ(e_j) e_i
    Ai = np.transpose(A, (2, 1, 0))  # (i, row, j)
    Gx = -0.5 * xi_matrix(x)  # [A_1 x̂, A_2 x̂, A_3 x̂]
    P = Gx @ Pmu @ Gx.T
    if q_cov is not None:
        W = Pmu if mu_mean is None else Pmu + np.outer(mu_mean, mu_mean)
        Ge = np.concatenate(list(Ai), axis=1)  # (4, 12)
        P = P + Ge @ np.kron(W, np.asarray(q_cov, dtype=np.float64)) @ Ge.T
    return 0.5 * (P + P.T)


def pseudo_observation_model(B: ArrayLike, R_ref: ArrayLike, sigma: ArrayLike,
                             q_hat: ArrayLike, P: ArrayLike | None = None, *,
                             index: int = 0, project: bool = True) -> Measurement:
    r"""Pseudo-observation measurement for vector observations, linear in the quaternion.

    Parameters
    ----------
    B, R_ref : array_like, shape (3,) or (k, 3)
        Measured body-frame vectors and their navigation-frame references.
    sigma : float, (3,) or (3, 3)
        Noise of each body-frame measurement (the same for all ``k``).
    q_hat : array_like, shape (4,)
        Prior (predicted) attitude mean, where the noise and the projection are evaluated.
    P : array_like, shape (3, 3), optional
        Prior tangent covariance of the attitude (right perturbation); enters the noise
        through the second moment of :math:`q = \hat q \otimes \mathrm{Exp}(\delta)`,
        :math:`E[qq^\top] \approx (1 - \mathrm{tr}P/4)\,\hat q\hat q^\top +
        \tfrac14\Xi P\Xi^\top` (eq. 15 needs :math:`P_X + \hat X\hat X^\top`; taking
        :math:`\hat X = \hat q` would over-state it by :math:`\tfrac14\mathrm{tr}P\,
        \hat q\hat q^\top`).
    index : int
        Where the quaternion starts in the state's ambient coordinates
        (``X[:, index:index + 4]``), e.g. 0 for a ``Product([UnitQuaternion(), ...])``.
    project : bool
        Project each 4-vector onto :math:`\hat q^\perp` (3 components, positive definite
        noise; default).  ``False`` keeps 4 components whose noise is singular along
        :math:`\hat q` when ``P`` is None (given by a non-square factor; only the
        square-root forms can use it).

    Returns
    -------
    Measurement
        ``h(X)`` of dimension ``3k`` (or ``4k``); observe ``z = 0``.
    """
    B = np.atleast_2d(np.asarray(B, dtype=np.float64))
    R = np.atleast_2d(np.asarray(R_ref, dtype=np.float64))
    G = pseudo_observation_matrix(B, R)  # (k, 4, 4)
    k = G.shape[0]
    q_hat = np.asarray(q_hat, dtype=np.float64)
    Xi = xi_matrix(q_hat)
    Pq, x = None, q_hat
    if P is not None:
        P = np.asarray(P, dtype=np.float64)
        Pq = 0.25 * Xi @ P @ Xi.T
        # E[q q^T] for q = q_hat ⊗ Exp(δ), δ ~ N(0, P), to second order is
        # (1 - tr P / 4) q_hat q_hat^T + Pq: the mean shrinks along q_hat
        x = np.sqrt(max(0.0, 1.0 - 0.25 * float(np.trace(P)))) * q_hat
    Pv = pseudo_observation_noise(x, Pq, sigma)
    if project:
        T = Xi.T
        G = T @ G  # (k, 3, 4)
        Pv = T @ Pv @ T.T
        Pv = 0.5 * (Pv + Pv.T)
    sl = slice(index, index + 4)

    def h(X: Array) -> Array:
        return np.einsum("kij,mj->mki", G, X[:, sl]).reshape(X.shape[0], -1)

    if project:
        noise = Noise.from_cov(np.kron(np.eye(k), Pv))
    else:
        lam, U = np.linalg.eigh(Pv)
        keep = lam > 1e-14 * max(lam.max(), np.finfo(float).tiny)
        noise = Noise.from_sqrt(np.kron(np.eye(k), U[:, keep] * np.sqrt(lam[keep])))
    return Measurement(h, noise)
