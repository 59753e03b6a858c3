r"""Euler-angle sequences and the [Wang SRCKF-SLAM] (paper) attitude convention.

Two intrinsic Tait-Bryan sequences are provided, both giving the body-to-navigation
rotation ``q_nb`` (see :mod:`nav.quaternion` for the quaternion conventions):

* aerospace Z-Y-X: yaw :math:`\psi` about Z, then pitch :math:`\theta` about the new
  Y, then roll :math:`\phi` about the new X,

  .. math:: C_{nb} = R_z(\psi)\, R_y(\theta)\, R_x(\phi);

* the paper's Z-X-Y: yaw :math:`\gamma` about Z, then roll :math:`\alpha` about
  the new X, then pitch :math:`\beta` about the new Y,

  .. math:: C_{nb} = R_z(\gamma)\, R_x(\alpha)\, R_y(\beta).

Angle arrays are always ordered ``[roll, pitch, yaw]``.  The middle angle lies in
:math:`[-\pi/2, \pi/2]`, the others in :math:`[-\pi, \pi)`.

The inverse maps work on the quaternion directly: with half angles :math:`a, b, c` of
the last, middle and first rotation, sums and differences of quaternion components
factor as (for Z-Y-X) :math:`w \pm y = (\cos b \pm \sin b)\cos(a \mp c)` and
:math:`x \mp z = (\cos b \pm \sin b)\sin(a \mp c)`, so

.. math::

    a + c = \operatorname{atan2}(x + z, w - y), \quad
    a - c = \operatorname{atan2}(x - z, w + y), \quad
    b + \tfrac{\pi}{4} = \operatorname{atan2}(\lVert(w+y, x-z)\rVert,
    \lVert(w-y, x+z)\rVert),

which stays accurate everywhere, including near gimbal lock.  At gimbal lock (middle
angle within a few :math:`10^{-10}` rad of :math:`\pm\pi/2`) the last angle is set to 0
and the first absorbs the whole rotation about the locked axis (the rotation is then
reproduced to about 1e-9 instead of round-off).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators.spaces import wrap_angle

from .quaternion import qexp, qmul

Array = NDArray[np.float64]

#: Relative size of the vanishing factor below which a sequence is treated as locked.
GIMBAL_LOCK_TOL = 1e-10

__all__ = [
    "GIMBAL_LOCK_TOL",
    "dcm_nb_from_paper",
    "euler_zyx_errors",
    "euler_zxy_to_q",
    "euler_zyx_to_q",
    "q_from_paper",
    "q_to_euler_zxy",
    "q_to_euler_zyx",
    "q_to_paper",
]


def _axis_q(angle: ArrayLike, axis: int) -> Array:
    """Quaternion of a rotation by ``angle`` about coordinate axis ``axis`` (0, 1, 2)."""
    half = 0.5 * np.asarray(angle, dtype=np.float64)
    q = np.zeros(half.shape + (4,))
    q[..., 0] = np.cos(half)
    q[..., 1 + axis] = np.sin(half)
    return q


def _tait_bryan(sum_yx: tuple[Array, Array], dif_yx: tuple[Array, Array]) -> Array:
    """Shared inverse for a Tait-Bryan sequence with half angles a (last), b, c (first).

    ``sum_yx`` is a (sin-like, cos-like) pair with atan2 :math:`a + c` and norm
    :math:`\\propto \\cos b - \\sin b`; ``dif_yx`` likewise for :math:`a - c` with norm
    :math:`\\propto \\cos b + \\sin b`.  Returns unwrapped ``(2a, 2b, 2c)``, shape (..., 3).
    """
    hs = np.hypot(*sum_yx)  # vanishes at middle angle = +π/2
    hd = np.hypot(*dif_yx)  # vanishes at middle angle = -π/2
    middle = 2.0 * np.arctan2(hd, hs) - 0.5 * np.pi
    s = np.arctan2(*sum_yx)  # a + c
    d = np.arctan2(*dif_yx)  # a - c
    tol = GIMBAL_LOCK_TOL * (hs + hd)
    lock_up, lock_down = hs <= tol, hd <= tol
    last = np.where(lock_up | lock_down, 0.0, s + d)
    first = np.where(lock_up, -2.0 * d, np.where(lock_down, 2.0 * s, s - d))
    return np.stack([last, middle, first], axis=-1)


def euler_zyx_to_q(roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike) -> Array:
    r"""Aerospace Z-Y-X Euler angles to ``q_nb``.

    .. math::

        q_{nb} = q_z(\psi) \otimes q_y(\theta) \otimes q_x(\phi), \qquad
        C_{nb} = R_z(\psi)\, R_y(\theta)\, R_x(\phi).

    Equivalent to ``scipy.spatial.transform.Rotation.from_euler('ZYX', [yaw, pitch,
    roll])``.

    Parameters
    ----------
    roll, pitch, yaw : array_like, shape (...)
        :math:`\phi, \theta, \psi` (rad); broadcast against each other.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return qmul(qmul(_axis_q(yaw, 2), _axis_q(pitch, 1)), _axis_q(roll, 0))


def q_to_euler_zyx(q: ArrayLike) -> Array:
    r"""``q_nb`` to aerospace Z-Y-X Euler angles ``[roll, pitch, yaw]``.

    Inverse of :func:`euler_zyx_to_q`: roll :math:`\phi \in [-\pi, \pi)`,
    pitch :math:`\theta \in [-\pi/2, \pi/2]`, yaw :math:`\psi \in [-\pi, \pi)`.
    With half angles :math:`a = \phi/2, b = \theta/2, c = \psi/2`:

    .. math::

        \phi \pm \psi = 2\,\operatorname{atan2}(x \pm z,\, w \mp y), \qquad
        \theta = 2\operatorname{atan2}(\lVert(w+y, x-z)\rVert, \lVert(w-y, x+z)\rVert)
        - \pi/2.

    At gimbal lock (:math:`\theta = \pm\pi/2`) roll is set to 0.  Invariant to
    the sign and (positive) scale of ``q``.

    Shapes: ``q`` (..., 4) → (..., 3), ``[roll, pitch, yaw]`` (rad).
    """
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll, pitch, yaw = np.moveaxis(_tait_bryan((x + z, w - y), (x - z, w + y)), -1, 0)
    return np.stack([wrap_angle(roll), pitch, wrap_angle(yaw)], axis=-1)


def euler_zxy_to_q(roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike) -> Array:
    r"""The paper's Z-X-Y Euler angles to ``q_nb``.

    Yaw :math:`\gamma` about Z, then roll :math:`\alpha` about the new X, then pitch
    :math:`\beta` about the new Y:

    .. math::

        q_{nb} = q_z(\gamma) \otimes q_x(\alpha) \otimes q_y(\beta), \qquad
        C_{nb} = R_z(\gamma)\, R_x(\alpha)\, R_y(\beta).

    Equivalent to ``Rotation.from_euler('ZXY', [yaw, roll, pitch])``.

    Parameters
    ----------
    roll, pitch, yaw : array_like, shape (...)
        :math:`\alpha` (about X), :math:`\beta` (about Y), :math:`\gamma` (about Z), rad.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return qmul(qmul(_axis_q(yaw, 2), _axis_q(roll, 0)), _axis_q(pitch, 1))


def q_to_euler_zxy(q: ArrayLike) -> Array:
    r"""``q_nb`` to the paper's Z-X-Y Euler angles ``[roll α, pitch β, yaw γ]``.

    Inverse of :func:`euler_zxy_to_q`: roll :math:`\alpha \in [-\pi/2, \pi/2]` (the
    middle angle), pitch :math:`\beta \in [-\pi, \pi)`, yaw :math:`\gamma \in [-\pi, \pi)`.
    With half angles :math:`a = \alpha/2, b = \beta/2, c = \gamma/2` one has
    :math:`w \pm x = (\cos a \pm \sin a)\cos(b \pm c)`,
    :math:`z \pm y = (\cos a \pm \sin a)\sin(c \pm b)`, hence

    .. math::

        \gamma \pm \beta = 2\,\operatorname{atan2}(z \pm y,\, w \pm x), \qquad
        \alpha = 2\operatorname{atan2}(\lVert(w+x, z+y)\rVert, \lVert(w-x, z-y)\rVert)
        - \pi/2.

    At gimbal lock (:math:`\alpha = \pm\pi/2`) pitch is set to 0.

    Shapes: ``q`` (..., 4) → (..., 3), ``[roll, pitch, yaw]`` = ``[α, β, γ]`` (rad).
    """
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    # Half angles b (pitch, last), a (roll, middle), c (yaw, first): atan2(y - z, w - x)
    # = b - c with norm ∝ cos a - sin a, atan2(z + y, w + x) = b + c with norm
    # ∝ cos a + sin a.  _tait_bryan then sees "a + c" = b - c, i.e. its first angle is -γ.
    pitch, roll, neg_yaw = np.moveaxis(_tait_bryan((y - z, w - x), (z + y, w + x)), -1, 0)
    return np.stack([roll, wrap_angle(pitch), wrap_angle(-neg_yaw)], axis=-1)


def q_from_paper(q_paper: ArrayLike) -> Array:
    r"""Seed-004 quaternion :math:`[q_1, q_2, q_3, q_4]` (:math:`q_1` scalar) to ``q_nb``.

    The paper's direction-cosine matrix in terms of its quaternion, eq. (5),

    .. math::

        C_n^b = \begin{bmatrix}
        q_1^2+q_2^2-q_3^2-q_4^2 & 2(q_2q_3+q_1q_4) & 2(q_2q_4-q_1q_3) \\
        2(q_2q_3-q_1q_4) & q_1^2-q_2^2+q_3^2-q_4^2 & 2(q_3q_4+q_1q_2) \\
        2(q_2q_4+q_1q_3) & 2(q_3q_4-q_1q_2) & q_1^2-q_2^2-q_3^2+q_4^2
        \end{bmatrix},

    is element for element :math:`C(q)^T` with :math:`q = [q_1, q_2, q_3, q_4]`, where
    :math:`C(q)` is this project's body-to-navigation DCM (:func:`~nav.quaternion.qto_dcm`).
    Since the paper's :math:`C_n^b` maps navigation to body, :math:`C_n^b = C_{nb}^T`,
    the paper's quaternion *is* ``q_nb`` component for component: the conversion is the
    identity (a float copy).  This fact is checked in ``tests/test_rotations.py``.

    Shapes: ``q_paper`` (..., 4) → (..., 4), ``q_nb`` ``[w, x, y, z]`` (a new array).
    """
    return np.array(q_paper, dtype=np.float64, copy=True)


def q_to_paper(q: ArrayLike) -> Array:
    r"""``q_nb`` to the [Wang SRCKF-SLAM] quaternion :math:`[q_1, q_2, q_3, q_4]`.

    Inverse of :func:`q_from_paper`, hence also the identity on components (a copy).

    Shapes: ``q`` (..., 4) → (..., 4).
    """
    return np.array(q, dtype=np.float64, copy=True)


def dcm_nb_from_paper(C_n_b: ArrayLike) -> Array:
    r"""Paper's :math:`C_n^b` (navigation to body) to this project's ``C_nb``.

    :math:`C_{nb} = (C_n^b)^T`, transposing the last two axes.  Equivalently
    ``qto_dcm(q_from_paper(q_paper)) == dcm_nb_from_paper(C_n_b(q_paper))``.

    Shapes: ``C_n_b`` (..., 3, 3) → (..., 3, 3).
    """
    return np.array(np.swapaxes(np.asarray(C_n_b, dtype=np.float64), -1, -2), copy=True)


def euler_error_jacobian(q: ArrayLike, to_euler, eps: float = 1e-6) -> Array:
    r"""Derivative of Euler angles with respect to the body-frame attitude error.

    .. math::  J = \frac{\partial\, \mathrm{euler}(q \otimes \mathrm{Exp}(\delta))}
               {\partial \delta}\Big|_{\delta = 0}

    by central differences (angle differences wrapped), so a tangent covariance
    :math:`P_\delta` maps to Euler-angle covariance :math:`J P_\delta J^\top`.

    Parameters
    ----------
    q : array_like, shape (M, 4)
    to_euler : callable
        ``q (..., 4) -> (..., 3)``, e.g. :func:`q_to_euler_zyx` or :func:`q_to_euler_zxy`.

    Returns
    -------
    ndarray, shape (M, 3, 3)
    """
    q = np.asarray(q, dtype=float)
    steps = eps * np.eye(3)
    plus = to_euler(qmul(q[:, None, :], qexp(steps)[None]))
    minus = to_euler(qmul(q[:, None, :], qexp(-steps)[None]))
    return np.swapaxes(wrap_angle(plus - minus) / (2.0 * eps), -1, -2)


def euler_zyx_errors(qh: ArrayLike, P_att: ArrayLike, q_true: ArrayLike
                     ) -> tuple[Array, Array]:
    """``(err, sigma)`` (M, 3) of the Z-Y-X angles of ``qh`` against ``q_true`` (wrapped),
    sigma from the body-frame attitude covariance ``P_att`` (M, 3, 3) through
    :func:`euler_error_jacobian`; NaN rows where ``qh`` is not finite."""
    qh, P_att, q_true = (np.asarray(a, dtype=np.float64) for a in (qh, P_att, q_true))
    err = np.full(q_true.shape[:-1] + (3,), np.nan)
    sig = np.full_like(err, np.nan)
    ok = np.all(np.isfinite(qh), axis=1)
    if ok.any():
        err[ok] = wrap_angle(q_to_euler_zyx(qh[ok]) - q_to_euler_zyx(q_true[ok]))
        J = euler_error_jacobian(qh[ok], q_to_euler_zyx)
        with np.errstate(invalid="ignore"):
            C = J @ P_att[ok] @ np.swapaxes(J, -1, -2)
            sig[ok] = np.sqrt(np.diagonal(C, axis1=1, axis2=2))
    return err, sig
