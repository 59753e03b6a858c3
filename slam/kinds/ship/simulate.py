r"""Simulated ship: wave-induced attitude, a fibre-optic gyro and vector observations
([Ding 2017] §4, Table 1).

Frames
------
Navigation frame ``n``: local-level East-North-Up at the ship's site (it turns with the
Earth); body frame ``b``: forward-left-up; attitude ``q_nb`` (Hamilton, scalar first).
Euler angles are the aerospace Z-Y-X sequence of :mod:`nav.euler` (roll about the
forward axis, pitch about the left axis, yaw about up, counter-clockwise from East); the
paper names roll, pitch and yaw without a sequence.

Truth (the ship at rest on the water, rocked by waves)
-------------------------------------------------------
.. math::

    \phi(t) = A_r \sin(2\pi t/T_r + \varphi_r),\quad
    \theta(t) = A_p \sin(2\pi t/T_p + \varphi_p),\quad
    \psi(t) = \psi_0 + A_y \sin(2\pi t/T_y + \varphi_y),

:math:`q_{nb}(t) = q_z(\psi) \otimes q_y(\theta) \otimes q_x(\phi)`, closed form at every
gyro epoch.  The IMU sits at the centre of the rotation and the ship neither heaves nor
surges, so the accelerometers sense gravity alone.

Gyro (rate ``1/dt``), with the Earth rate
-----------------------------------------
The body turns relative to the Earth-fixed ``n`` frame, which turns at
:math:`\omega_{ie}^n = \Omega [0, \cos L, \sin L]`; the gyro senses
:math:`\omega_{ib}^b = \omega_{nb}^b + C(q)^\top \omega_{ie}^n`.  Sample ``k`` covers
:math:`[t_k, t_{k+1}]` and is the exact increment of the strapdown model
:math:`q_{k+1} = \mathrm{Exp}(-\omega_{ie}^n dt) \otimes q_k \otimes \mathrm{Exp}(\omega_k dt)`
(the one :func:`nav.strapdown.ideal_imu` inverts) plus the drift and the noise:

.. math::

    \tilde\omega_k = \mathrm{Log}(q_k^* \otimes \mathrm{Exp}(\omega_{ie}^n dt)
    \otimes q_{k+1})/dt + b_k + n_k,\quad n_k \sim N(0, \sigma_{arw}^2/dt),\quad
    b_{k+1} = b_k + \sigma_{rw}\sqrt{dt}\, m_k,

([Ding 2017] eq. 5: :math:`\bar\omega = \omega + \alpha + \mu_v`, :math:`\dot\alpha = \mu_u`).

Vector observations (every ``samples_per_update`` gyro samples, first at t = 0)
-------------------------------------------------------------------------------
[Ding 2017] eq. (7) with :math:`C(q)` mapping ``n`` to ``b`` (our :math:`C(q_{nb})^\top`):
:math:`\bar B_j = C(q)^\top R_j + \mu_j`, :math:`\mu_j \sim N(0, \sigma_j^2 I_3)`, a snapshot
at the update epoch, for two unit references: the specific force at rest (up,
:math:`R_1 = [0, 0, 1]`, σ in g) and the geomagnetic field direction
:math:`R_2 = [\cos I \sin D, \cos I \cos D, -\sin I]` (declination ``D`` east of north,
inclination ``I`` below the horizon; σ as a fraction of the field).

Randomness comes only from the generator passed in, drawn in a fixed order: wave phases,
the gyro's errors (:func:`nav.imu_errors.corrupt_imu`: drift random walk, angle random
walk, with its unused accelerometer draws), vector noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nav.arrays import read_only
from nav.euler import euler_zyx_to_q
from nav.imu_errors import ImuErrors, corrupt_imu
from nav.quaternion import qconj, qexp, qlog, qmul, qrotate
from nav.strapdown import earth_rate_enu
from slam.kinds.ship.world import ShipWorld

Array = NDArray[np.float64]

__all__ = ["ShipLog", "field_direction", "simulate_ship", "truth_attitude", "wave_angles"]


def field_direction(declination: float, inclination: float) -> Array:
    """Unit geomagnetic field direction in ENU (declination east of north, inclination
    below the horizon)."""
    ci = math.cos(inclination)
    return np.array([ci * math.sin(declination), ci * math.cos(declination),
                     -math.sin(inclination)])


@dataclass(frozen=True, eq=False)
class ShipLog:
    """One simulated run (arrays read-only, SI units).

    times : (N + 1,) gyro epochs; gyro : (N, 3) rad/s, sample ``k`` covers
        ``[t_k, t_{k+1}]``; truth_q : (N + 1, 4) ``q_nb``; truth_bias : (N + 1, 3) rad/s,
        ``truth_bias[k]`` is the drift during sample ``k``.
    update_index : (M,) gyro epoch of each vector epoch; vectors : (M, 2, 3) measured
        ``B̄_j`` (gravity, field); refs : (2, 3) ``R_j``; sigmas : (2,) their σ.
    earth_rate : (3,) ``ω_ie^n``; euler : (N + 1, 3) true roll/pitch/yaw (Z-Y-X).
    """

    dt: float
    samples_per_update: int
    times: Array
    gyro: Array
    truth_q: Array
    truth_bias: Array
    update_index: NDArray[np.int64]
    vectors: Array
    refs: Array
    sigmas: Array
    earth_rate: Array
    euler: Array

    n_updates = property(lambda self: len(self.update_index), doc="vector epochs (M)")
    update_times = property(lambda self: self.times[self.update_index],
                            doc="(M,) times of the vector epochs")
    update_truth_q = property(lambda self: self.truth_q[self.update_index],
                              doc="(M, 4) true attitude at the vector epochs")
    update_truth_bias = property(lambda self: self.truth_bias[self.update_index],
                                 doc="(M, 3) true drift at the vector epochs")

    def gyro_block(self, j: int) -> Array:
        """(samples_per_update, 3) gyro samples from vector epoch ``j`` to ``j + 1``."""
        s = self.samples_per_update
        return self.gyro[j * s:(j + 1) * s]


def wave_angles(world: ShipWorld, t: Array, phases: Array) -> Array:
    """``[roll, pitch, yaw]`` (len(t), 3) of the wave motion (module docstring)."""
    w = world.waves
    amp = np.array([w.roll_amplitude_rad, w.pitch_amplitude_rad, w.yaw_amplitude_rad])
    period = np.array([w.roll_period_s, w.pitch_period_s, w.yaw_period_s])
    ang = amp * np.sin(2.0 * np.pi * np.asarray(t)[:, None] / period + phases)
    ang[:, 2] += w.heading_rad
    return ang


def truth_attitude(world: ShipWorld, t: Array, phases: Array) -> tuple[Array, Array]:
    """``(q_nb (len(t), 4), euler (len(t), 3))`` of the wave motion."""
    e = wave_angles(world, t, phases)
    return euler_zyx_to_q(e[:, 0], e[:, 1], e[:, 2]), e


def simulate_ship(world: ShipWorld, rng: np.random.Generator) -> ShipLog:
    """Simulate one run of truth, gyro and vector observations (module docstring)."""
    g, v = world.gyro, world.vectors
    dt, s = g.dt_s, world.samples_per_update
    M = world.n_updates
    N = (M - 1) * s
    times = np.arange(N + 1) * dt
    phases = (rng.uniform(0.0, 2.0 * np.pi, 3) if world.waves.random_phases
              else np.zeros(3))
    q, euler = truth_attitude(world, times, phases)
    wie = earth_rate_enu(world.site.latitude_rad)
    rate = qlog(qmul(qmul(qconj(q[:-1]), qexp(wie * dt)), q[1:])) / dt

    errors = ImuErrors(0.0, g.bias_rw_rad_s_sqrt_s, g.arw_rad_sqrt_s, 0.0, 0.0, 0.0)
    imu = corrupt_imu(rate, np.zeros_like(rate), dt, errors, rng)  # the accelerometer unused
    drift = np.asarray(g.bias_rad_s)
    gyro, bias = imu.gyro + drift, imu.bias_gyro + drift

    index = np.arange(M, dtype=np.int64) * s
    refs = np.array([[0.0, 0.0, 1.0],
                     field_direction(v.field_declination_rad, v.field_inclination_rad)])
    sigmas = np.array([v.gravity_sigma, v.magnetometer_sigma])
    body = qrotate(qconj(q[index])[:, None, :], refs[None, :, :])  # (M, 2, 3): C(q)ᵀ R_j
    vectors = body + sigmas[None, :, None] * rng.standard_normal((M, 2, 3))
    return ShipLog(dt=dt, samples_per_update=s, times=read_only(times), gyro=read_only(gyro),
                   truth_q=read_only(q), truth_bias=read_only(bias), update_index=read_only(index),
                   vectors=read_only(vectors), refs=read_only(refs), sigmas=read_only(sigmas),
                   earth_rate=read_only(wie), euler=read_only(euler))
