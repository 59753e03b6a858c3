r"""Hamilton unit quaternions, rotation vectors and direction-cosine matrices.

Conventions (fixed for the whole project)
-----------------------------------------
* Quaternions are Hamilton, scalar first: ``q = [w, x, y, z]``,
  :math:`q = w + x\,i + y\,j + z\,k` with :math:`ijk = -1`.
* ``q_nb`` maps body-frame vectors to the navigation frame,

  .. math:: v_n = C(q_{nb})\, v_b = q_{nb} \otimes [0, v_b] \otimes q_{nb}^{*}.

* Attitude errors are right (body-frame) perturbations,
  :math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)`.
* Radians everywhere.

Every function broadcasts over leading batch axes: quaternions are ``(..., 4)``,
vectors ``(..., 3)``, matrices ``(..., 3, 3)``.  Inputs are never modified.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

#: Below this angle (rad) :func:`qexp` and :func:`qlog` switch to Taylor series.
SMALL_ANGLE = 1e-4

__all__ = [
    "points_and_weights",
    "SMALL_ANGLE",
    "dcm_to_q",
    "dcm_to_rotvec",
    "omega_matrix",
    "qconj",
    "qexp",
    "qleft_matrix",
    "qlog",
    "qmul",
    "qnormalize",
    "qpropagate",
    "qright_matrix",
    "qrotate",
    "qto_dcm",
    "rotvec_to_dcm",
    "skew",
]


def _f(a: ArrayLike) -> Array:
    return np.asarray(a, dtype=np.float64)


def _product_table() -> Array:
    """``T`` (16, 4) with ``p ⊗ q = vec(p qᵀ) @ T``: entry ``(4i + j, k)`` is the sign
    with which :math:`p_i q_j` enters component :math:`k` of the Hamilton product."""
    T = np.zeros((16, 4))
    for i, j, k, sign in (
        (0, 0, 0, 1), (1, 1, 0, -1), (2, 2, 0, -1), (3, 3, 0, -1),
        (0, 1, 1, 1), (1, 0, 1, 1), (2, 3, 1, 1), (3, 2, 1, -1),
        (0, 2, 2, 1), (1, 3, 2, -1), (2, 0, 2, 1), (3, 1, 2, 1),
        (0, 3, 3, 1), (1, 2, 3, 1), (2, 1, 3, -1), (3, 0, 3, 1),
    ):
        T[4 * i + j, k] = sign
    T.setflags(write=False)
    return T


_PRODUCT_TABLE = _product_table()


def _cross(a: Array, b: Array) -> Array:
    """Broadcasting cross product of ``(..., 3)`` arrays."""
    a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2]
    b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1], axis=-1)


def skew(v: ArrayLike) -> Array:
    r"""Cross-product (skew-symmetric) matrix.

    .. math::

        [v]_\times = \begin{bmatrix} 0 & -v_3 & v_2 \\ v_3 & 0 & -v_1 \\
        -v_2 & v_1 & 0 \end{bmatrix}, \qquad [v]_\times u = v \times u.

    Shapes: ``v`` (..., 3) → (..., 3, 3).
    """
    v = _f(v)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def qmul(p: ArrayLike, q: ArrayLike) -> Array:
    r"""Hamilton product :math:`p \otimes q`.

    .. math::

        p \otimes q = \begin{bmatrix} p_w q_w - p_v \cdot q_v \\
        p_w q_v + q_w p_v + p_v \times q_v \end{bmatrix}.

    With the body-to-navigation convention, :math:`C(p \otimes q) = C(p)\,C(q)`.

    Shapes: ``p``, ``q`` (..., 4), broadcast against each other → (..., 4).
    """
    p, q = _f(p), _f(q)
    outer = p[..., :, None] * q[..., None, :]  # p_i q_j, then one (16, 4) matmul
    return outer.reshape(outer.shape[:-2] + (16,)) @ _PRODUCT_TABLE


def qleft_matrix(a: Array) -> Array:
    r"""The (4, 4) matrix of left multiplication by one quaternion ``a`` (4,):
    :math:`a \otimes b = L(a)\,b`, so a batch ``b`` (m, 4) gives ``b @ L(a).T``."""
    w, x, y, z = a.tolist()
    return np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])


def qright_matrix(a: Array) -> Array:
    r"""The (4, 4) matrix of right multiplication by one quaternion ``a`` (4,):
    :math:`b \otimes a = R(a)\,b`, so a batch ``b`` (m, 4) gives ``b @ R(a).T``."""
    w, x, y, z = a.tolist()
    return np.array([[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]])


def qconj(q: ArrayLike) -> Array:
    r"""Conjugate :math:`q^* = [w, -x, -y, -z]` (the inverse of a unit quaternion).

    Shapes: ``q`` (..., 4) → (..., 4).
    """
    return _f(q) * np.array([1.0, -1.0, -1.0, -1.0])


def qnormalize(q: ArrayLike) -> Array:
    r"""Scale to unit norm, :math:`q / \lVert q \rVert`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Must be non-zero.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = _f(q)
    if q.ndim == 1:
        return q / math.sqrt(float(q @ q))
    return q / np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]


def qexp(rotvec: ArrayLike) -> Array:
    r"""Exponential map: rotation vector to unit quaternion.

    .. math::

        \mathrm{Exp}(\theta) = \begin{bmatrix} \cos(\lVert\theta\rVert/2) \\
        \dfrac{\sin(\lVert\theta\rVert/2)}{\lVert\theta\rVert}\,\theta \end{bmatrix}.

    For :math:`\lVert\theta\rVert <` :data:`SMALL_ANGLE` the factor uses the series
    :math:`\sin(t/2)/t = 1/2 - t^2/48 + t^4/3840 - \dots` (truncation error below
    :math:`10^{-19}` relative), so there is no division by zero at :math:`\theta = 0`.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vector (axis times angle, rad).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion.
    """
    r = _f(rotvec)
    if r.ndim == 1:  # one rotation vector: scalar arithmetic, same branches
        t2 = float(r @ r)
        if t2 < SMALL_ANGLE * SMALL_ANGLE:
            k = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0
            w = 1.0 - t2 / 8.0 + t2 * t2 / 384.0 - t2 * t2 * t2 / 46080.0
        else:
            t = math.sqrt(t2)
            k, w = math.sin(0.5 * t) / t, math.cos(0.5 * t)
        return np.array([w, k * r[0], k * r[1], k * r[2]])
    t2 = np.einsum("...i,...i->...", r, r)
    series = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0
    out = np.empty(r.shape[:-1] + (4,))
    if t2.max(initial=0.0) < SMALL_ANGLE * SMALL_ANGLE:  # every angle takes the series
        out[..., 0] = 1.0 - t2 / 8.0 + t2 * t2 / 384.0 - t2 * t2 * t2 / 46080.0
        out[..., 1:] = series[..., None] * r
        return out
    t = np.sqrt(t2)
    small = t < SMALL_ANGLE
    safe_t = np.where(small, 1.0, t)
    k = np.where(small, series, np.sin(0.5 * safe_t) / safe_t)
    out[..., 0] = np.cos(0.5 * t)
    out[..., 1:] = k[..., None] * r
    return out


def qlog(q: ArrayLike) -> Array:
    r"""Logarithm map: unit quaternion to rotation vector in the ball :math:`|\theta| \le \pi`.

    The representative with :math:`w \ge 0` is used (``q`` and ``-q`` give the same
    result), then

    .. math::

        \mathrm{Log}(q) = \frac{2\,\operatorname{atan2}(\lVert v\rVert, w)}{\lVert v\rVert}\, v,
        \qquad q = [w, v].

    ``atan2`` keeps full accuracy near :math:`0` and near :math:`\pi` (where ``acos``
    of ``w`` loses half the digits).  For :math:`\lVert v\rVert < 10^{-4}\,w` the factor
    uses the series :math:`2\arctan(s)/\lVert v\rVert = (2/w)(1 - s^2/3 + s^4/5)` with
    :math:`s = \lVert v\rVert / w`.  The formula is invariant to positive scaling of
    ``q``, so a slightly non-unit quaternion is treated as its normalisation.

    Shapes: ``q`` (..., 4) → (..., 3), Rotation vector with norm in :math:`[0, \pi]`.
    """
    q = _f(q)
    v = q[..., 1:]
    n2 = np.einsum("...i,...i->...", v, v)
    w = q[..., 0]
    if np.all(n2 < (SMALL_ANGLE * SMALL_ANGLE) * (w * w)):  # every rotation takes the series
        s2 = n2 / (w * w)  # w² > 0 here, even where w² would underflow elsewhere
        return ((2.0 / w) * (1.0 - s2 / 3.0 + s2 * s2 / 5.0))[..., None] * v
    sign = np.where(w < 0.0, -1.0, 1.0)  # the w >= 0 representative
    w = sign * w
    n = np.sqrt(n2)
    small = n < SMALL_ANGLE * w
    w_small = np.where(small, w, 1.0)  # small implies w > 0
    s2 = np.where(small, (n / w_small) ** 2, 0.0)
    safe_n = np.where(small | (n == 0.0), 1.0, n)
    k = np.where(
        small,
        (2.0 / w_small) * (1.0 - s2 / 3.0 + s2 * s2 / 5.0),
        2.0 * np.arctan2(n, w) / safe_n,
    )
    return (sign * k)[..., None] * v


def qrotate(q: ArrayLike, v: ArrayLike) -> Array:
    r"""Rotate vectors: :math:`q \otimes [0, v] \otimes q^* = C(q)\,v`.

    Evaluated as :math:`t = 2\,q_v \times v`, :math:`v' = v + q_w t + q_v \times t`
    (valid for unit ``q``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternion(s).
    v : array_like, shape (..., 3)
        Vector(s); broadcast against ``q``'s leading axes.

    Returns
    -------
    ndarray, shape (..., 3)
    """
    q, v = _f(q), _f(v)
    qw, qv = q[..., :1], q[..., 1:]
    t = 2.0 * _cross(qv, v)
    return v + qw * t + _cross(qv, t)


def qto_dcm(q: ArrayLike) -> Array:
    r"""Direction-cosine matrix :math:`C(q)` with :math:`C v = q \otimes v \otimes q^*`.

    .. math::

        C = I + s\,(w\,[v]_\times + [v]_\times^2), \qquad s = 2 / \lVert q \rVert^2,

    i.e. for unit ``q``

    .. math::

        C = \begin{bmatrix}
        w^2+x^2-y^2-z^2 & 2(xy-wz) & 2(xz+wy) \\
        2(xy+wz) & w^2-x^2+y^2-z^2 & 2(yz-wx) \\
        2(xz-wy) & 2(yz+wx) & w^2-x^2-y^2+z^2 \end{bmatrix}.

    Using :math:`s = 2/\lVert q\rVert^2` makes the result orthogonal for any non-zero
    ``q`` (the DCM of the normalised quaternion).  For ``q_nb`` this is ``C_nb``.

    Shapes: ``q`` (..., 4) → (..., 3, 3).
    """
    q = _f(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    s = 2.0 / (w * w + x * x + y * y + z * z)
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return np.stack(
        [np.stack([1.0 - yy - zz, xy - wz, xz + wy], axis=-1),
         np.stack([xy + wz, 1.0 - xx - zz, yz - wx], axis=-1),
         np.stack([xz - wy, yz + wx, 1.0 - xx - yy], axis=-1)],
        axis=-2,
    )


def dcm_to_q(C: ArrayLike) -> Array:
    r"""Unit quaternion of a rotation matrix (Shepperd's method), with :math:`w \ge 0`.

    For a rotation :math:`C = C(q)` the symmetric matrix :math:`M = 4\,q q^T` is
    linear in :math:`C`:

    .. math::

        M_{ww} = 1 + \mathrm{tr}\,C, \quad M_{xx} = 1 + 2C_{11} - \mathrm{tr}\,C, \quad
        M_{yy} = 1 + 2C_{22} - \mathrm{tr}\,C, \quad M_{zz} = 1 + 2C_{33} - \mathrm{tr}\,C,

        M_{wx} = C_{32} - C_{23}, \quad M_{wy} = C_{13} - C_{31}, \quad
        M_{wz} = C_{21} - C_{12},

        M_{xy} = C_{12} + C_{21}, \quad M_{xz} = C_{13} + C_{31}, \quad
        M_{yz} = C_{23} + C_{32}.

    The column with the largest diagonal entry (:math:`\ge 1`, since the diagonal
    sums to 4) is :math:`4 q_k q`; normalising it gives ``q`` without any small
    divisor, including at :math:`180^\circ` rotations where :math:`w \approx 0`.
    The branch is chosen per element with ``argmax``.  A slightly non-orthogonal
    ``C`` yields a unit quaternion close to it.

    Shapes: ``C`` (..., 3, 3) → (..., 4), Unit quaternion with non-negative scalar part.
    """
    C = _f(C)
    c00, c01, c02 = C[..., 0, 0], C[..., 0, 1], C[..., 0, 2]
    c10, c11, c12 = C[..., 1, 0], C[..., 1, 1], C[..., 1, 2]
    c20, c21, c22 = C[..., 2, 0], C[..., 2, 1], C[..., 2, 2]
    tr = c00 + c11 + c22
    dw, dx, dy, dz = 1.0 + tr, 1.0 + 2.0 * c00 - tr, 1.0 + 2.0 * c11 - tr, 1.0 + 2.0 * c22 - tr
    wx, wy, wz = c21 - c12, c02 - c20, c10 - c01
    xy, xz, yz = c01 + c10, c02 + c20, c12 + c21
    M = np.stack(
        [np.stack([dw, wx, wy, wz], axis=-1),
         np.stack([wx, dx, xy, xz], axis=-1),
         np.stack([wy, xy, dy, yz], axis=-1),
         np.stack([wz, xz, yz, dz], axis=-1)],
        axis=-2,
    )
    k = np.argmax(np.stack([dw, dx, dy, dz], axis=-1), axis=-1)
    col = np.take_along_axis(M, k[..., None, None], axis=-1)[..., 0]
    q = qnormalize(col)
    return np.where(q[..., :1] < 0.0, -q, q)


def rotvec_to_dcm(rotvec: ArrayLike) -> Array:
    r"""Rotation matrix :math:`C(\mathrm{Exp}(\theta))` (Rodrigues), via :func:`qexp`.

    Shapes: ``rotvec`` (..., 3) → (..., 3, 3).
    """
    return qto_dcm(qexp(rotvec))


def dcm_to_rotvec(C: ArrayLike) -> Array:
    r"""Rotation vector :math:`\mathrm{Log}(C)` with norm in :math:`[0, \pi]`.

    Computed as ``qlog(dcm_to_q(C))``.

    Shapes: ``C`` (..., 3, 3) → (..., 3).
    """
    return qlog(dcm_to_q(C))


def omega_matrix(omega: ArrayLike) -> Array:
    r"""4x4 matrix :math:`\Omega(\omega)` with :math:`q \otimes [0, \omega] = \Omega(\omega)\,q`.

    .. math::

        \Omega(\omega) = \begin{bmatrix} 0 & -\omega^T \\ \omega & -[\omega]_\times
        \end{bmatrix}, \qquad \Omega^2 = -\lVert\omega\rVert^2 I_4,

    so the attitude kinematics :math:`\dot q = \tfrac12 q \otimes [0, \omega]` read
    :math:`\dot q = \tfrac12 \Omega(\omega)\,q`.

    Shapes: ``omega`` (..., 3) → (..., 4, 4).
    """
    om = _f(omega)
    top = np.concatenate([np.zeros_like(om[..., :1]), -om], axis=-1)[..., None, :]
    bottom = np.concatenate([om[..., :, None], -skew(om)], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


def qpropagate(q: ArrayLike, omega: ArrayLike, dt: ArrayLike) -> Array:
    r"""Propagate an attitude over one interval with constant body rate (closed form).

    Exact solution of :math:`\dot q = \tfrac12 q \otimes [0, \omega]` for constant
    :math:`\omega` over :math:`[t_k, t_k + \Delta t]`:

    .. math::

        q_{k+1} = q_k \otimes \begin{bmatrix} \cos(\Delta\theta/2) \\
        \sin(\Delta\theta/2)\, \omega / \lVert\omega\rVert \end{bmatrix}
        = q_k \otimes \mathrm{Exp}(\omega\,\Delta t),
        \qquad \Delta\theta = \lVert\omega\rVert\,\Delta t.

    This is the closed form of the matrix-exponential update of [Wang SRCKF-SLAM] eq. (10):
    since :math:`\Omega^2 = -\lVert\omega\rVert^2 I` (see :func:`omega_matrix`),

    .. math::

        \exp(\tfrac12 \Omega\,\Delta t)
        = \cos(\Delta\theta/2)\, I_4 + \frac{\sin(\Delta\theta/2)}{\Delta\theta}\,\Omega\,\Delta t,

    and :math:`\exp(\tfrac12\Omega\Delta t)\,q_k = q_k \otimes \mathrm{Exp}(\omega\Delta t)`.
    :math:`\omega \to 0` is handled by the series in :func:`qexp`.  The result is
    renormalised to stop round-off drift over many steps.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Attitude at :math:`t_k` (``q_nb``).
    omega : array_like, shape (..., 3)
        Body angular rate (rad/s), constant over the interval.
    dt : array_like, shape (...)
        Interval length (s); scalar or broadcastable to the batch axes.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    dtheta = _f(omega) * _f(dt)[..., None]
    return qnormalize(qmul(q, qexp(dtheta)))


def points_and_weights(points: ArrayLike, weights: ArrayLike) -> tuple[Array, Array, int]:
    """``(points (..., m, 4), weights (..., m), m)`` as float arrays, shapes checked
    (``ValueError`` naming the shape otherwise)."""
    pts = np.asarray(points, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    if pts.ndim < 2 or pts.shape[-1] != 4:
        raise ValueError(f"points must have shape (..., m, 4), got {pts.shape}")
    m = pts.shape[-2]
    if w.ndim < 1 or w.shape[-1] != m:
        raise ValueError(f"weights must have shape (..., {m}), got {w.shape}")
    return pts, w, m
