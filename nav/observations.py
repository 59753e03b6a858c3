r"""Attitude measurement models for the filters, as :class:`estimators.Measurement` values.

The state starts with the attitude ``q = q_nb`` (Hamilton, scalar first; body to navigation
frame), followed by ``rest_dim`` other tangent coordinates (3 for the gyro bias of
:mod:`nav.gyro`), e.g. on ``Product([UnitQuaternion(), Euclidean(3)])``.  Jacobians are
in the tangent coordinates of the right (body-frame) perturbation
:math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)`.

* :func:`quaternion_measurement` - a measured attitude, :math:`z = q \boxplus v` on
  :class:`~nav.spaces.UnitQuaternion`; innovation :math:`\mathrm{Log}(\hat z^* \otimes z)`,
  :math:`H = [I_3\ 0]`.
* :func:`direction_measurement` - body-frame readings of known navigation-frame unit
  directions :math:`r_j` (star tracker, sun sensor, gravity):
  :math:`z = [C(q)^\top r_1; \dots; C(q)^\top r_k] + v`.
* :func:`magnetometer_measurement` - the body-frame field :math:`C(q)^\top m_n` of a
  navigation-frame field vector :math:`m_n` of any magnitude.

For a body-frame vector :math:`b = C(q)^\top r`,
:math:`C(q \otimes \mathrm{Exp}(\delta))^\top r = (I - [\delta\times]) b = b + [b\times]\delta`
to first order, so its Jacobian is :math:`[[b\times]\ 0]`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators.models import Measurement, Noise
from estimators.spaces import Euclidean

from .quaternion import qconj, qrotate, skew
from .spaces import UnitQuaternion

Array = NDArray[np.float64]

__all__ = ["direction_measurement", "magnetometer_measurement", "quaternion_measurement"]

#: Largest accepted deviation of a reference direction's norm from one.
UNIT_TOL = 1e-6


def _sigmas(sigma: float | ArrayLike, shape: tuple[int, ...]) -> Array:
    """``sigma`` broadcast to ``shape`` and flattened (a fresh array); must be > 0."""
    s = np.asarray(sigma, dtype=np.float64)
    try:
        out = np.broadcast_to(s, shape).ravel().copy()
    except ValueError as exc:
        raise ValueError(f"sigma of shape {s.shape} does not broadcast to {shape}") from exc
    if not np.all(out > 0.0):
        raise ValueError("measurement sigmas must be > 0")
    return out


def quaternion_measurement(sigma: float | ArrayLike, rest_dim: int = 3) -> Measurement:
    r"""A measured attitude quaternion: ``h(X) = X[:, :4]`` on ``UnitQuaternion``.

    ``sigma`` (rad): a scalar or a length-3 vector, the per-axis standard deviation of
    the body-frame rotation vector :math:`\mathrm{Log}(q^* \otimes z)`.  Analytic
    Jacobian :math:`[I_3\ 0_{3\times r}]` with :math:`r` = ``rest_dim``.
    """
    H = np.hstack([np.eye(3), np.zeros((3, rest_dim))])
    return Measurement(lambda X: X[..., :4], Noise.from_sigmas(_sigmas(sigma, (3,))),
                       UnitQuaternion(), jacobian=lambda x: H)


def _body_vectors(vectors: Array, sigmas: Array, rest_dim: int) -> Measurement:
    """``h(X)`` stacks ``C(q)^T v_j`` for the rows ``v_j`` of ``vectors`` (k, 3)."""
    k = vectors.shape[0]

    def h(X: Array) -> Array:
        return qrotate(qconj(X[..., None, :4]), vectors).reshape(X.shape[:-1] + (3 * k,))

    def jac(x: Array) -> Array:
        b = qrotate(qconj(x[..., None, :4]), vectors)  # (..., k, 3)
        lead = x.shape[:-1]
        return np.concatenate([skew(b).reshape(lead + (3 * k, 3)),
                               np.zeros(lead + (3 * k, rest_dim))], axis=-1)

    return Measurement(h, Noise.from_sigmas(sigmas), Euclidean(3 * k), jacobian=jac)


def direction_measurement(refs: ArrayLike, sigma: float | ArrayLike,
                          rest_dim: int = 3) -> Measurement:
    r"""Body-frame readings of ``k`` known navigation-frame unit directions.

    ``h(X)`` stacks :math:`C(q)^\top r_j` (ambient :math:`3k`, on
    :math:`\mathbb R^{3k}`); analytic Jacobian rows :math:`[[C^\top r_j \times]\ 0]`.

    Parameters
    ----------
    refs : array_like, shape (k, 3) or (3,)
        Unit reference directions :math:`r_j` in the navigation frame.
    sigma : float or array_like
        Standard deviation of each reading's components, broadcast against (k, 3): a
        scalar, a (3,) vector per body axis, a (k, 1) column per reference, or (k, 3).
        The radial component carries no attitude information to first order; a unit
        reading's radial variance is not in the data, so it only lowers the NIS.
    rest_dim : int
        Tangent dimensions after the attitude (Jacobian zero columns).

    Raises
    ------
    ValueError
        If a reference is not a unit vector (within :data:`UNIT_TOL`) or ``sigma`` does
        not broadcast.
    """
    r = np.asarray(refs, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.abs(np.linalg.norm(r, axis=1) - 1.0) <= UNIT_TOL):
        raise ValueError("direction references must be unit vectors; "
                         "use magnetometer_measurement for a field of any magnitude")
    return _body_vectors(r, _sigmas(sigma, r.shape), rest_dim)


def magnetometer_measurement(field_n: ArrayLike, sigma: float | ArrayLike,
                             rest_dim: int = 3) -> Measurement:
    r"""A magnetometer: the body-frame field :math:`C(q)^\top m_n`.

    ``field_n`` (3,) is the navigation-frame field in any unit (nT, µT, or a unit
    vector); ``sigma`` (same unit) a scalar or a per-axis (3,) noise standard deviation.
    Analytic Jacobian :math:`[[C^\top m_n \times]\ 0]`.
    """
    m = np.asarray(field_n, dtype=np.float64).reshape(1, 3)
    if not (np.all(np.isfinite(m)) and np.linalg.norm(m) > 0.0):
        raise ValueError("the field vector must be non-zero and finite")
    return _body_vectors(m, _sigmas(sigma, (3,)), rest_dim)
