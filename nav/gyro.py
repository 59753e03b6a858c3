r"""Gyro interval propagation and process noise for an attitude-and-gyro-bias state.

State and chart
---------------
``x = [q, b]``: ``q`` the Hamilton, scalar-first unit quaternion ``q_nb`` (4 numbers), ``b``
the gyro bias (rad/s, 3), on ``Product([UnitQuaternion(), Euclidean(3)])`` (ambient 7,
tangent 6).  Errors are body-frame right perturbations,
:math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)`, :math:`b = \hat b + \delta b`.

Propagation over one interval of ``n`` gyro samples :math:`\tilde\omega_k` spaced ``dt``
(the bias held constant over the interval):

.. math::

    q' = q \otimes \prod_{k=0}^{n-1} \mathrm{Exp}((\tilde\omega_k - b)\,dt), \qquad b' = b.

Process noise, additive in the tangent at the end of the interval :math:`T = n\,dt`, from
the error dynamics :math:`\dot{\delta\theta} = -[\hat\omega\times]\delta\theta - \delta b
- n_g`, :math:`\dot{\delta b} = n_b` with white-noise densities :math:`\Sigma_g` (angle
random walk) and :math:`\Sigma_b` (bias random walk):

.. math::

    Q = \begin{bmatrix} \Sigma_g T + \Sigma_b T^3/3 & -\Sigma_b T^2/2 \\
        -\Sigma_b T^2/2 & \Sigma_b T \end{bmatrix}.

The rotation :math:`\mathrm{Exp}(-[\hat\omega\times]s)` that carries noise injected at
:math:`T - s` to the end of the interval is neglected.  It leaves :math:`\Sigma_g T`
unchanged for an isotropic :math:`\Sigma_g` (and never enters :math:`\Sigma_b T`); in the
bias-driven attitude terms, and in :math:`\Sigma_g T` for an anisotropic :math:`\Sigma_g`,
it is a relative :math:`O(|\hat\omega| T)` change.

Densities are given per axis (:func:`density_matrix`): a scalar :math:`\sigma` (the same
on every axis, :math:`\Sigma = \sigma^2 I`), a length-3 vector :math:`\sigma_i`
(:math:`\Sigma = \mathrm{diag}(\sigma_i^2)`), or a full 3x3 covariance density
:math:`\Sigma`.  Units: ``arw`` rad/√s (Σ in rad²/s), ``bias_rw`` rad/s/√s (Σ in rad²/s³).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators.models import Noise, Transition

from .quaternion import qexp, qmul, qnormalize

Array = NDArray[np.float64]

__all__ = [
    "dead_reckoning",
    "density_matrix",
    "interval_noise",
    "interval_transition",
    "ordered_product",
    "propagate_points",
]


def density_matrix(value: float | ArrayLike, name: str = "density") -> Array:
    r"""The 3x3 covariance density :math:`\Sigma` of a per-axis noise specification.

    ``value`` is a scalar :math:`\sigma` (:math:`\sigma^2 I_3`), a length-3 vector of
    :math:`\sigma_i` (:math:`\mathrm{diag}(\sigma_i^2)`), or a symmetric positive
    semi-definite 3x3 matrix :math:`\Sigma` (returned symmetrised).

    Raises
    ------
    ValueError
        On another shape, a non-finite value, a negative sigma, or a matrix that is not
        symmetric positive semi-definite.
    """
    v = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    if v.ndim == 0:
        if v < 0.0:
            raise ValueError(f"{name}: sigma must be >= 0, got {float(v)}")
        return float(v) ** 2 * np.eye(3)
    if v.shape == (3,):
        if np.any(v < 0.0):
            raise ValueError(f"{name}: sigmas must be >= 0, got {v}")
        return np.diag(v**2)
    if v.shape == (3, 3):
        if not np.allclose(v, v.T, rtol=1e-12, atol=0.0):
            raise ValueError(f"{name}: the 3x3 density must be symmetric")
        S = 0.5 * (v + v.T)
        if np.min(np.linalg.eigvalsh(S)) < -1e-12 * max(np.max(np.abs(S)), 1e-300):
            raise ValueError(f"{name}: the 3x3 density must be positive semi-definite")
        return S
    raise ValueError(f"{name}: expected a scalar, a length-3 vector or a 3x3 matrix, "
                     f"got shape {v.shape}")


def ordered_product(E: Array) -> Array:
    r"""``E[..., 0, :] ⊗ E[..., 1, :] ⊗ ⋯ ⊗ E[..., n-1, :]`` by pairwise (tree) reduction.

    The ``n`` quaternions are padded with identities to a power of two, then multiplied
    in adjacent pairs, :math:`\lceil \log_2 n \rceil` batched products in all.
    """
    n = E.shape[-2]
    size = 1 << max(n - 1, 0).bit_length()
    if size != n:  # pad with identities to a power of two: no odd leftovers to carry
        pad = np.zeros(E.shape[:-2] + (size - n, 4))
        pad[..., 0] = 1.0
        E = np.concatenate([E, pad], axis=-2)
    while E.shape[-2] > 1:
        E = qmul(E[..., 0::2, :], E[..., 1::2, :])
    return E[..., 0, :]


def propagate_points(X: Array, gyro: Array, dt: float) -> Array:
    r"""Carry states ``X`` (m, 7) through the gyro samples ``gyro`` (n, 3) of one interval
    (a batch of runs: ``X`` (..., m, 7) with ``gyro`` (..., n, 3)).

    :math:`q' = \mathrm{normalize}(q \otimes \prod_k \mathrm{Exp}((\tilde\omega_k - b)\,dt))`,
    :math:`b' = b`; all points and samples at once (one batched ``qexp``).
    """
    q, b = X[..., :4], X[..., 4:]
    m, n = X.shape[-2], gyro.shape[-2]
    lead = np.broadcast_shapes(X.shape[:-2], gyro.shape[:-2])
    size = 1 << max(n - 1, 0).bit_length()  # padded with identities to a power of two
    E = np.zeros(lead + (m, size, 4))
    E[..., n:, 0] = 1.0
    E[..., :n, :] = qexp((gyro[..., None, :, :] - b[..., :, None, :]) * dt)
    out = np.empty(lead + X.shape[-2:])
    out[..., :4] = qnormalize(qmul(q, ordered_product(E)))
    out[..., 4:] = b
    return out


def interval_noise(T: float, arw: float | ArrayLike, bias_rw: float | ArrayLike) -> Array:
    r"""Tangent-space process noise (6, 6) of one interval of length ``T`` (seconds).

    :math:`Q_{\theta\theta} = \Sigma_g T + \Sigma_b T^3/3`,
    :math:`Q_{\theta b} = Q_{b\theta} = -\Sigma_b T^2/2`, :math:`Q_{bb} = \Sigma_b T`, with
    :math:`\Sigma_g` = ``density_matrix(arw)`` and :math:`\Sigma_b` =
    ``density_matrix(bias_rw)`` (module docstring).
    """
    Ga = density_matrix(arw, "arw")
    Gb = density_matrix(bias_rw, "bias_rw")
    Q = np.zeros((6, 6))
    Q[:3, :3] = Ga * T + Gb * T**3 / 3.0
    cross = -0.5 * Gb * T**2
    Q[:3, 3:] = cross
    Q[3:, :3] = cross.T
    Q[3:, 3:] = Gb * T
    return Q


def interval_transition(n: int, dt: float, arw: float | ArrayLike,
                        bias_rw: float | ArrayLike) -> Transition:
    r"""One interval of ``n`` gyro samples spaced ``dt`` as a :class:`estimators.Transition`.

    ``f(X, u)`` is :func:`propagate_points` with ``u`` the interval's (n, 3) gyro samples;
    the noise is additive, :math:`Q` = ``interval_noise(n * dt, arw, bias_rw)`` plus
    :math:`10^{-30} I_6` (a zero bias random walk would make :math:`Q` singular; this keeps
    its Cholesky factor defined).  No analytic Jacobian: the EKF differentiates ``f``
    numerically through the spaces.
    """
    Q = interval_noise(n * dt, arw, bias_rw)
    # a zero bias random walk would make Q singular; keep its factor well defined
    Q = Q + 1e-30 * np.eye(6)

    def f(X: Array, u: Array) -> Array:
        return propagate_points(X, np.asarray(u, dtype=np.float64), dt)

    return Transition(f, Noise.from_cov(Q), additive=True)


def dead_reckoning(q0: ArrayLike, gyro_blocks: Iterable[ArrayLike], dt: float,
                   bias: ArrayLike | None = None) -> Array:
    r"""Attitude from ``q0`` and the gyro alone, at the end of every block.

    ``gyro_blocks`` yields the (n_j, 3) samples of consecutive intervals (a (3,) row is
    one sample); :math:`q_{j+1} = \mathrm{normalize}(q_j \otimes \prod_k
    \mathrm{Exp}((\tilde\omega_k - b)\,dt))` with a constant ``bias`` (zero if ``None``).

    Returns
    -------
    ndarray, shape (M + 1, 4)
        ``q0`` followed by the attitude after each of the ``M`` blocks.
    """
    q = np.asarray(q0, dtype=np.float64)[None, :4]
    b = None if bias is None else np.asarray(bias, dtype=np.float64)
    out = [q[0]]
    for block in gyro_blocks:
        w = np.atleast_2d(np.asarray(block, dtype=np.float64))
        rates = w if b is None else w - b
        q = qnormalize(qmul(q, ordered_product(qexp(rates * dt))[None]))
        out.append(q[0])
    return np.array(out)
