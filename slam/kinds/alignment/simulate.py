r"""Simulated launcher: swaying attitude, wind deflection, IMU with Markov errors, and
the SINS mechanised from the IMU ([Wu-Wang 2014] §4).

Frames
------
Navigation frame ``n``: local-level East-North-Up at the site (it turns with the Earth);
body frame ``b``: forward-left-up; attitude ``q_nb`` (Hamilton, scalar first), Z-Y-X
Euler angles of :mod:`nav.euler`.  The launcher elevation ``E`` (nose up) is the Z-Y-X
pitch ``-E`` (a positive pitch about the left axis lowers the nose).

Truth
-----
:math:`E(t) = E_0 + A_E \sin(2\pi f_E t + \varphi_E)`, roll
:math:`\phi(t) = \phi_0 + A_\phi \sin(2\pi f_\phi t + \varphi_\phi)`, heading fixed.  The IMU
sits at the centre of the sway; the wind (eq. 13) deflects the launcher horizontally by
:math:`d = c\,(w(t) - \bar w)`, so the IMU's true velocity is :math:`v = c\,\dot w(t)`
(East, North; zero up).  The mean wind's static deflection is part of the surveyed
position.

IMU (``rate_hz``, sample ``k`` covers :math:`[t_k, t_{k+1}]`)
-------------------------------------------------------------
Gyro: :math:`\tilde\omega_k = \mathrm{Log}(q_k^* \otimes \mathrm{Exp}(\omega_{ie}^n dt)
\otimes q_{k+1})/dt + b_g + m_g(t_k) + n_k` (the exact inverse of the attitude update
:func:`nav.strapdown.attitudes`).  Accelerometer: the specific force is held constant in
the navigation frame over each filter interval ``j`` (``T``),
:math:`f^n_j = (v_{j+1} - v_j)/T - g^n + 2\omega_{ie}^n \times v_j`, read in the body frame
at every sample, :math:`\tilde f_k = C(q_k)^\top f^n_j + b_a + m_a(t_k) + n_k`.
:math:`b` is a random constant, :math:`m` a stationary first-order Markov sequence
(:func:`markov`), :math:`n` white; σ's from the world.

SINS (the alignment's mechanisation)
------------------------------------
Attitude every IMU sample (the paper's 1 ms update), from the misaligned start
:math:`\hat q_0 = \mathrm{Exp}(-\phi_0) \otimes q_0` (:math:`\phi_0` the nav-frame
misalignment): :math:`\hat q_{k+1} = \mathrm{Exp}(-\omega_{ie}^n dt) \otimes \hat q_k \otimes
\mathrm{Exp}(\tilde\omega_k dt)`.  Velocity per filter interval, from zero:

.. math::

    \hat V_{j+1} = \hat V_j + \sum_{k \in j} C(\hat q_k)\,\tilde f_k\,dt
        + (g^n - 2\,\omega_{ie}^n \times \hat V_j)\,T .

The sum is evaluated from the interval increments (:class:`Increments`, the ones the
filters' error model uses) as :math:`\hat C_j\Delta v_j - [\omega_{ie}^n]_\times \hat C_j
\Delta v_{1,j}`: exact except for the Earth's turn inside the 0.1 s interval, kept to
first order (about 3e-11 m/s per interval).  With error-free readings and no
misalignment the SINS reproduces the truth at the filter epochs (the tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nav.arrays import read_only
from nav.imu_errors import first_order_markov
from nav.quaternion import qconj, qexp, qlog, qmul, qrotate, qto_dcm, skew
from nav.strapdown import G0, earth_rate_enu, gravity_enu, hamilton, prefix_products
from slam.kinds.alignment.world import AlignmentWorld

Array = NDArray[np.float64]

__all__ = ["AlignmentLog", "Increments", "increments", "markov", "mechanise",
           "simulate_alignment", "sway_attitude", "wind_velocity"]


@dataclass(frozen=True, eq=False)
class Increments:
    r"""Per filter interval ``j`` (body frame at the interval's start, ``i`` its samples,
    :math:`\Delta R_i` the gyro's rotation from the start to sample ``i``, Earth rate
    removed):

    dq : (M-1, 4) :math:`\Delta R` over the interval; A : (M-1, 3, 3) its drift
    Jacobian, :math:`\Delta R(\varepsilon) \approx \Delta R\,\mathrm{Exp}(-A\varepsilon)`;
    dv : (M-1, 3) :math:`\sum_i \Delta R_i \tilde f_i dt`; dv1 : :math:`\sum_i \tau_i
    \Delta R_i \tilde f_i dt` (:math:`\tau_i` time into the interval);
    B_acc : (M-1, 3, 3) :math:`\sum_i \Delta R_i dt`; B_gyro : (M-1, 3, 3)
    :math:`\sum_i \Delta R_i [\tilde f_i]_\times A_i dt` (first-order drift effect on dv).
    """

    dq: Array
    A: Array
    dv: Array
    dv1: Array
    B_acc: Array
    B_gyro: Array


@dataclass(frozen=True, eq=False)
class AlignmentLog:
    """One simulated run (arrays read-only, SI units) at the filter epochs ``j``.

    times : (M,) epochs; truth_q : (M, 4) ``q_nb``; truth_v : (M, 3) true velocity;
    sins_q : (M, 4), sins_v : (M, 3) the SINS's attitude and velocity;
    gyro_drift, accel_bias : (M, 3) true total gyro drift / accelerometer bias at the
    epoch; inc : the interval increments; earth_rate (3,), gravity (3,);
    dt, T : IMU and filter intervals; misalignment (3,) the initial one.
    gyro, accel : (N, 3) the readings (kept for the smoother).
    """

    dt: float
    T: float
    times: Array
    truth_q: Array
    truth_v: Array
    sins_q: Array
    sins_v: Array
    gyro_drift: Array
    accel_bias: Array
    inc: Increments
    earth_rate: Array
    gravity: Array
    misalignment: Array
    gyro: Array
    accel: Array

    n_epochs = property(lambda self: len(self.times), doc="filter epochs (M)")


def _zyx(roll: Array, pitch: Array, yaw: float) -> Array:
    """Z-Y-X Euler angles to ``q_nb`` in closed form (equals
    :func:`nav.euler.euler_zyx_to_q`)."""
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    return np.stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy], axis=-1)


def sway_attitude(world: AlignmentWorld, t: Array, phases: Array) -> Array:
    """``q_nb`` (len(t), 4) of the swaying launcher (module docstring)."""
    s = world.sway
    t = np.asarray(t, dtype=np.float64)
    elev = s.elevation_rad + s.elevation_amplitude_rad * np.sin(
        2.0 * np.pi * s.elevation_frequency_hz * t + phases[0])
    roll = s.roll_rad + s.roll_amplitude_rad * np.sin(
        2.0 * np.pi * s.roll_frequency_hz * t + phases[1])
    return _zyx(roll, -elev, s.heading_rad)


def wind_velocity(world: AlignmentWorld, t: Array) -> Array:
    r"""The IMU's velocity (len(t), 3) from the wind deflection:
    :math:`c\,\dot w(t)`, :math:`\dot w = \sum_i 2\pi f_i a_i \cos(2\pi f_i t + \varphi_i)`."""
    w = world.wind
    t = np.asarray(t, dtype=np.float64)[:, None]
    f, ph = np.asarray(w.frequency_hz), np.asarray(w.phase_rad)
    cos = 2.0 * np.pi * f * np.cos(2.0 * np.pi * f * t + ph)
    v = np.zeros((t.shape[0], 3))
    v[:, 0] = cos @ np.asarray(w.amplitude_x_mps)
    v[:, 1] = cos @ np.asarray(w.amplitude_y_mps)
    return v * w.compliance_m_per_mps


def markov(n: int, sigma: float, tau: float, dt: float, rng: np.random.Generator) -> Array:
    r"""(n, 3) stationary first-order Gauss-Markov sequence:
    :math:`m_{k+1} = e^{-dt/\tau} m_k + \sigma\sqrt{1 - e^{-2dt/\tau}}\,\eta_k`,
    :math:`m_0 \sim N(0, \sigma^2)` (drawn: m_0, then the n - 1 steps)."""
    a = math.exp(-dt / tau)
    m0 = rng.standard_normal(3) * sigma
    drive = rng.standard_normal((n - 1, 3)) * (sigma * math.sqrt(1.0 - a * a))
    return first_order_markov(m0, drive, a)


def increments(gyro: Array, accel: Array, s: int, dt: float) -> Increments:
    """The interval increments of :class:`Increments` from the readings (N, 3)."""
    M1 = gyro.shape[0] // s
    tau = np.arange(s) * dt
    dR = prefix_products(qexp(gyro.reshape(M1, s, 3) * dt))  # (M1, s + 1, 4)
    C_all = qto_dcm(dR)  # (M1, s + 1, 3, 3)
    C, C_end = C_all[:, :-1], C_all[:, -1]
    f = accel.reshape(M1, s, 3)
    Cf = (C @ f[..., None])[..., 0] * dt
    # A_i = C_i^T S_i, S_i = sum_{k < i} C_{k+1} dt
    S = np.cumsum(C_all[:, 1:], axis=1) * dt
    S_before = np.concatenate([np.zeros((M1, 1, 3, 3)), S[:, :-1]], axis=1)
    A_i = np.swapaxes(C, -1, -2) @ S_before
    A = np.swapaxes(C_end, -1, -2) @ S[:, -1]
    B_gyro = (C @ skew(f) @ A_i).sum(axis=1) * dt
    return Increments(dq=read_only(dR[:, -1]), A=read_only(A), dv=read_only(Cf.sum(axis=1)),
                      dv1=read_only(np.einsum("i,jia->ja", tau, Cf)),
                      B_acc=read_only(C.sum(axis=1) * dt), B_gyro=read_only(B_gyro))


def mechanise(q0: Array, inc: Increments, T: float, gravity: Array, earth_rate: Array
              ) -> tuple[Array, Array]:
    r"""The SINS at the filter epochs from the increments: ``(q (M, 4), V (M, 3))``,
    :math:`\hat q_j = \mathrm{Exp}(-\omega_{ie}^n jT) \otimes q_0 \otimes \prod_{i<j}
    \Delta R_i` and the velocity recursion of the module docstring with
    :math:`\sum_k C(\hat q_k)\tilde f_k dt = \hat C_j(\Delta v - [\omega_{ie}^n]_\times
    \ldots)`, i.e. :math:`\hat C_j \Delta v - [\omega_{ie}^n]_\times \hat C_j \Delta v_1`
    (the Earth's turn inside the interval to first order)."""
    M = inc.dq.shape[0] + 1
    q = prefix_products(inc.dq[None], q0)[0]
    q = hamilton(qexp(-np.arange(M)[:, None] * T * earth_rate), q)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    C = qto_dcm(q[:-1])
    W = skew(earth_rate)
    d = (C @ inc.dv[..., None])[..., 0] - ((W @ C) @ inc.dv1[..., None])[..., 0] + gravity * T
    F = np.eye(3) - 2.0 * T * W
    V = np.zeros((M, 3))
    for j in range(M - 1):
        V[j + 1] = F @ V[j] + d[j]
    return q, V


def _imu_errors(world: AlignmentWorld, n: int, rng: np.random.Generator) -> tuple[Array, ...]:
    """``(gyro_err, accel_err, drift, bias)``: (n, 3) each; drift/bias without the white
    noise.  Draw order: constants (gyro, accel), Markov (gyro, accel), white (gyro, accel)."""
    m, dt = world.imu, world.imu.dt_s
    bg = rng.standard_normal(3) * m.gyro_bias_rad_s
    ba = rng.standard_normal(3) * m.accel_bias_mps2
    drift = bg + markov(n, m.gyro_markov_rad_s, m.gyro_markov_tau_s, dt, rng)
    bias = ba + markov(n, m.accel_markov_mps2, m.accel_markov_tau_s, dt, rng)
    ng = rng.standard_normal((n, 3)) * m.gyro_white_rad_s
    na = rng.standard_normal((n, 3)) * m.accel_white_mps2
    return drift + ng, bias + na, drift, bias


def simulate_alignment(world: AlignmentWorld, rng: np.random.Generator,
                       noise_scale: float = 1.0) -> AlignmentLog:
    """Simulate one run: truth, readings, the SINS and its increments (module docstring).
    ``noise_scale`` multiplies every IMU error (``0``: error-free readings)."""
    dt, s, M = world.imu.dt_s, world.samples_per_epoch, world.n_epochs
    N = (M - 1) * s
    T = s * dt
    t = np.arange(N + 1) * dt
    phases = rng.uniform(0.0, 2.0 * np.pi, 2) if world.sway.random_phases else np.zeros(2)
    q = sway_attitude(world, t, phases)
    wie, g = earth_rate_enu(world.site.latitude_rad), gravity_enu(G0)
    gyro_true = qlog(hamilton(hamilton(qconj(q[:-1]), qexp(wie * dt)), q[1:])) / dt
    te = t[::s]
    v = wind_velocity(world, te)
    fn = np.diff(v, axis=0) / T - g + 2.0 * np.cross(wie, v[:-1])
    accel_true = qrotate(qconj(q[:-1]), np.repeat(fn, s, axis=0))
    ge, ae, drift, bias = _imu_errors(world, N, rng)
    gyro = gyro_true + noise_scale * ge
    accel = accel_true + noise_scale * ae
    phi0 = np.asarray(world.filters.initial_misalignment_rad)
    inc = increments(gyro, accel, s, dt)
    sins_q, sins_v = mechanise(qmul(qexp(-phi0), q[0]), inc, T, g, wie)
    epoch_k = np.minimum(np.arange(M) * s, N - 1)
    return AlignmentLog(dt=dt, T=T, times=read_only(te), truth_q=read_only(q[::s]),
                        truth_v=read_only(v), sins_q=read_only(sins_q), sins_v=read_only(sins_v),
                        gyro_drift=read_only(noise_scale * drift[epoch_k]),
                        accel_bias=read_only(noise_scale * bias[epoch_k]), inc=inc,
                        earth_rate=read_only(wie), gravity=read_only(g),
                        misalignment=read_only(phi0), gyro=read_only(gyro), accel=read_only(accel))
