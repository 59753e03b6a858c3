r"""The Euler-angle (EA) attitude model of [Fixed-wing EA-UKF] §5.1-5.2.

State :math:`x = [\phi, \theta, \psi, g_p, g_q, g_r]` (Z-Y-X roll, pitch, yaw; gyro
biases, rad/s) on ``Wrapped(6, (0, 2))`` (roll and yaw wrapped).

Process (eq. 5-6, 9-11): the Euler-rate kinematics

.. math::

    \begin{bmatrix}\dot\phi\\ \dot\theta\\ \dot\psi\end{bmatrix} = T(\phi, \theta)\,\omega,
    \qquad T = \begin{bmatrix}1 & s_\phi t_\theta & c_\phi t_\theta\\
    0 & c_\phi & -s_\phi\\ 0 & s_\phi/c_\theta & c_\phi/c_\theta\end{bmatrix},

with the body rate relative to the navigation frame
:math:`\omega = \bar{\tilde\omega} - g - C(x_0)^\top\omega_{ie}^n` (the epoch's mean gyro
reading, delta-angle over the epoch; the Earth rate projected at the epoch's start),
integrated by one classical Runge-Kutta step over the epoch; the biases are held.
Process noise (additive, at the prior mean): :math:`T\,\sigma_g^2\tau\,T^\top` on the angles
(gyro white noise over the epoch :math:`\tau`) and a bias random walk :math:`q_g^2\tau`
(the gyro's Markov drift density: over an epoch of 0.2 s and :math:`T_a` of minutes the
Markov process is a random walk).

Measurement (eq. 13-14): roll and pitch from the accelerometer as if it sensed gravity
only, heading from the tilt-compensated magnetometer.  With the body specific force
:math:`f` (the epoch's mean accelerometer reading; at rest :math:`f = C^\top[0, 0, g]`)

.. math::

    \phi_m = \operatorname{atan2}(f_y, f_z),\quad
    \theta_m = \operatorname{atan2}(-f_x, \sqrt{f_y^2 + f_z^2}),\quad
    \psi_m = \operatorname{atan2}(m^n_N, m^n_E) - \operatorname{atan2}(l_y, l_x),

:math:`l = R_y(\theta_m)R_x(\phi_m)\,m_b` the levelled field.  The filter observes
:math:`z = [\phi_m, \theta_m, \psi_m] = [\phi, \theta, \psi] + v` with the assumed
:math:`R = \mathrm{diag}(\sigma_{rp}^2, \sigma_{rp}^2, \sigma_h^2)`.  In a coordinated turn
or an acceleration the specific force is not gravity and :math:`\phi_m, \theta_m` are
wrong by up to the bank angle: the error source this model carries into its estimate.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators import Measurement, Noise, Transition, Wrapped
from nav.euler import euler_zyx_to_q
from nav.ins import psd_sqrt
from nav.quaternion import qconj, qrotate

Array = NDArray[np.float64]
SPACE = Wrapped(6, (0, 2))
ANGLES = Wrapped(3, (0, 2))

__all__ = ["SPACE", "accel_mag_angles", "ea_measurement", "ea_transition", "euler_rates"]


def euler_rates(angles: Array, omega: Array) -> Array:
    """:math:`T(\\phi, \\theta)\\,\\omega` (eq. 6) for rows of angles and body rates."""
    phi, theta = angles[..., 0], angles[..., 1]
    sp, cp = np.sin(phi), np.cos(phi)
    ct = np.cos(theta)
    a = omega[..., 1] * sp + omega[..., 2] * cp
    return np.stack([omega[..., 0] + a * np.tan(theta),
                     omega[..., 1] * cp - omega[..., 2] * sp, a / ct], axis=-1)


def euler_matrix(angles: ArrayLike) -> Array:
    """The 3x3 matrix :math:`T(\\phi, \\theta)` of eq. 11 at one set of angles."""
    phi, theta = float(angles[0]), float(angles[1])
    sp, cp, ct, tt = np.sin(phi), np.cos(phi), np.cos(theta), np.tan(theta)
    return np.array([[1.0, sp * tt, cp * tt], [0.0, cp, -sp], [0.0, sp / ct, cp / ct]])


def rk4(angles: Array, omega: Array, h: float) -> Array:
    """One classical Runge-Kutta step of eq. 6 with the body rate held."""
    k1 = euler_rates(angles, omega)
    k2 = euler_rates(angles + 0.5 * h * k1, omega)
    k3 = euler_rates(angles + 0.5 * h * k2, omega)
    k4 = euler_rates(angles + h * k3, omega)
    return angles + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def earth_rate_body(x: Array, earth_rate: Array | None) -> Array:
    """:math:`C(x)^\\top\\omega_{ie}^n` at one state (zeros without Earth rate)."""
    if earth_rate is None:
        return np.zeros(3)
    q = euler_zyx_to_q(x[0], x[1], x[2])
    return qrotate(qconj(q), np.asarray(earth_rate, dtype=np.float64))


def ea_transition(x_mean: Array, tau: float, arw: float, bias_rw: float,
                  earth_rate: Array | None) -> Transition:
    """One EA epoch of length ``tau``; ``u`` is the epoch's mean gyro reading (3,)."""
    wie_b = earth_rate_body(x_mean, earth_rate)
    T = euler_matrix(x_mean)
    Q = np.zeros((6, 6))
    Q[:3, :3] = T @ T.T * (arw**2 * tau)
    Q[3:, 3:] = np.eye(3) * (bias_rw**2 * tau)

    def f(X: Array, u: Array) -> Array:
        omega = u[None] - X[:, 3:] - wie_b[None]
        out = X.copy()
        out[:, :3] = rk4(X[:, :3], omega, tau)
        return SPACE.retract(out, np.zeros_like(out))

    return Transition(f, Noise(Q, psd_sqrt(Q)), additive=True)


def accel_mag_angles(f: Array, m: Array, field_n: Array) -> Array:
    """``[φ_m, θ_m, ψ_m]`` (eq. 13, module docstring) from body specific force ``f`` and
    field ``m`` (..., 3)."""
    phi = np.arctan2(f[..., 1], f[..., 2])
    theta = np.arctan2(-f[..., 0], np.hypot(f[..., 1], f[..., 2]))
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    ly = cp * m[..., 1] - sp * m[..., 2]
    lx = ct * m[..., 0] + st * (sp * m[..., 1] + cp * m[..., 2])
    psi = np.arctan2(field_n[1], field_n[0]) - np.arctan2(ly, lx)
    return ANGLES.retract(np.stack([phi, theta, psi], axis=-1), 0.0)


def ea_measurement(roll_pitch_sigma: float, heading_sigma: float) -> Measurement:
    """The linear measurement :math:`z = [\\phi, \\theta, \\psi] + v` (module docstring)."""
    R = np.diag([roll_pitch_sigma**2, roll_pitch_sigma**2, heading_sigma**2])
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    return Measurement(lambda X: X[:, :3], Noise.from_cov(R), space=ANGLES,
                       jacobian=lambda x: H)
