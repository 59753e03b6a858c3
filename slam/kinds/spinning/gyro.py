r"""The spinning body's gyro and its resolution through the roll ([Spin SR-CH∞KF] eq. 1-3).

The gyro measures the body-frame rates.  Its roll channel :math:`\omega_x` saturates (the
paper's "open circuit" axis); the two transverse channels :math:`\omega_y, \omega_z` spin
with the body.  For :math:`C_{nb} = R_y(\beta)R_z(\alpha)R_x(\gamma)`
(:mod:`slam.kinds.spinning.truth`) the body rate of Euler rates
:math:`(\dot\alpha, \dot\beta, \dot\gamma)` is

.. math::

    \omega_x = \dot\gamma + \dot\beta\sin\alpha,\qquad
    \omega_y = \dot\beta\cos\alpha\cos\gamma + \dot\alpha\sin\gamma,\qquad
    \omega_z = -\dot\beta\cos\alpha\sin\gamma + \dot\alpha\cos\gamma,

i.e. the transverse rate vector :math:`[\dot\beta\cos\alpha, \dot\alpha]` turned by the roll.
Eq. 3 integrates the inverse with the roll taken at the previous sample,

.. math::

    \dot\alpha = \omega_y\sin\gamma + \omega_z\cos\gamma,\qquad
    \dot\beta = (\omega_y\cos\gamma - \omega_z\sin\gamma)/\cos\alpha

(:func:`resolve`; eq. 1-3 as printed exchange α and β, see the truth module).  With a
roll error :math:`\delta` the resolved rates are the true transverse rate vector turned
by δ: a leak :math:`|\omega_\perp|\sin\delta` (e.g. 1.07°/s × sin 7° = 0.13°/s).

The roll the filters use comes from the magnetometer (eq. 7-8 on the measured radial
components with the filter's own pitch and yaw, :func:`magnetometer_roll`): the paper's
"the roll angle of the previous moment needed in the calculation of pitch angle and yaw
angle is measured by the geomagnetic sensor".  In the geomagnetic blind area the radial
field vanishes, that roll is lost, and its error leaks into pitch and yaw through eq. 3.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from slam.kinds.spinning.truth import Field, _pq, roll_from_field

Array = NDArray[np.float64]

__all__ = ["body_rates", "magnetometer_roll", "resolve", "roll_gradient"]


def body_rates(alpha: Array, gamma: Array, alpha_dot: Array, beta_dot: Array,
               gamma_dot: Array) -> Array:
    """``(..., 3)`` body rates :math:`[\\omega_x, \\omega_y, \\omega_z]` (module docstring)."""
    perp = beta_dot * np.cos(alpha)
    cg, sg = np.cos(gamma), np.sin(gamma)
    return np.stack([gamma_dot + beta_dot * np.sin(alpha), perp * cg + alpha_dot * sg,
                     -perp * sg + alpha_dot * cg], axis=-1)


def resolve(omega: Array, alpha: Array, gamma: Array) -> Array:
    """``(..., 2)`` pitch and yaw rates :math:`[\\dot\\alpha, \\dot\\beta]` from the
    transverse body rates ``omega`` ``(..., 2)`` = :math:`[\\omega_y, \\omega_z]`, the pitch
    and the roll (eq. 3's integrand, module docstring)."""
    wy, wz = omega[..., 0], omega[..., 1]
    cg, sg = np.cos(gamma), np.sin(gamma)
    return np.stack([wy * sg + wz * cg, (wy * cg - wz * sg) / np.cos(alpha)], axis=-1)


def magnetometer_roll(field: Field, x: Array, mag: Array) -> float:
    """The roll (rad) eq. 7-8 gives from one magnetometer reading ``mag`` (3,) (its radial
    components) and the estimate ``x = [α, β]``."""
    return float(roll_from_field(field, x[0], x[1], mag[1], mag[2]))


def roll_gradient(field: Field, x: Array, mag: Array) -> Array:
    r"""``(2,)`` :math:`[\partial\gamma/\partial\alpha, \partial\gamma/\partial\beta]` of
    :func:`magnetometer_roll` at fixed radial readings :math:`b_y, b_z`.

    With :math:`N = -Q b_y - P b_z`, :math:`M = P b_y - Q b_z`, :math:`\gamma =
    \operatorname{atan2}(N, M)`: :math:`d\gamma = (M\,dN - N\,dM)/(M^2 + N^2)`,
    :math:`dN = -b_y dQ - b_z dP`, :math:`dM = b_y dP - b_z dQ`, and
    :math:`\partial P/\partial\alpha = -B(\sin I\sin\alpha + \cos I\cos\alpha\cos(D-\beta))`,
    :math:`\partial P/\partial\beta = -B\cos I\sin\alpha\sin(D-\beta)`,
    :math:`\partial Q/\partial\alpha = 0`, :math:`\partial Q/\partial\beta = -B\cos I\cos(D-\beta)`.
    """
    B, I, D = field.intensity_nt, field.inclination_rad, field.declination_rad
    a, b = float(x[0]), float(x[1])
    by, bz = float(mag[1]), float(mag[2])
    p, q = (float(v) for v in _pq(field, np.asarray(a), np.asarray(b)))
    n, m = -q * by - p * bz, p * by - q * bz
    dp = np.array([-B * (math.sin(I) * math.sin(a) + math.cos(I) * math.cos(a) * math.cos(D - b)),
                   -B * math.cos(I) * math.sin(a) * math.sin(D - b)])
    dq = np.array([0.0, -B * math.cos(I) * math.cos(D - b)])
    dn, dm = -by * dq - bz * dp, by * dp - bz * dq
    return (m * dn - n * dm) / (m * m + n * n)
