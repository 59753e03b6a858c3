r"""The fixed-wing truth: a smooth flight path and the exact IMU readings that fly it.

Path
----
Speed :math:`V(t)`, flight-path angle :math:`\gamma(t)` and heading rate :math:`r(t)` (the
velocity's azimuth :math:`\psi` from East, counter-clockwise) are each a start value plus
smooth steps: manoeuvre ``i`` adds :math:`\Delta_i\,S((t - t_i)/T_i)` with the
cycloidal step

.. math::  S(s) = s - \frac{\sin 2\pi s}{2\pi}\ (0 \le s \le 1),\qquad S' = 1 - \cos 2\pi s,

(0 before, 1 after; :math:`C^2`), so the heading integrates in closed form,
:math:`\psi = \psi_0 + r_0 t + \sum_i \Delta r_i T_i J(s_i)` with
:math:`J(s) = s^2/2 + (\cos 2\pi s - 1)/(4\pi^2)` on :math:`[0, 1]` and :math:`J = s - 1/2`
after.  Velocity :math:`v = V[\cos\gamma\cos\psi, \cos\gamma\sin\psi, \sin\gamma]` (ENU)
and its derivative :math:`a` are analytic; the design position is the integral of
:math:`v`, three-point Gauss-Legendre per IMU interval (error far below 1e-9 m).

Attitude (coordinated flight, no sideslip, zero angle of attack): body x along
:math:`v`, body z along the part of the specific force :math:`a - g^n` normal to it,
:math:`y = z \times x`; so the accelerometer never senses a lateral force and the bank
angle is :math:`\arctan(V r \cos\gamma / \ldots)` - about :math:`\arctan(V r / g)`.

IMU readings: interval increments
---------------------------------
Like a real IMU's delta-angle and delta-velocity, reading ``k`` describes the whole
interval :math:`[t_k, t_{k+1}]`, not the rates at :math:`t_k`: it is the pair that
:func:`nav.strapdown.mechanise` integrates exactly, with its own scheme (a body rate and a
specific force constant in the body frame over the interval, gravity, and the Coriolis
term held at :math:`v_k`), from the truth at :math:`t_k` to the truth at :math:`t_{k+1}`.
:func:`nav.strapdown.ideal_imu` inverts that scheme:

.. math::

    \omega_k\Delta t = \mathrm{Log}\big(q_k^* \otimes \mathrm{Exp}(\omega_{ie}^n\Delta t)
        \otimes q_{k+1}\big),\qquad
    f_k = \Gamma_1(\omega_k\Delta t)^{-1} C(q_k)^\top
        \Big(\frac{\tilde v_{k+1} - \tilde v_k}{\Delta t} - g^n
             + 2\,\omega_{ie}^n \times \tilde v_k\Big),

so the mechanised attitude is the design attitude and the mechanised velocity is
:math:`\tilde v` at every sample, to round-off.

Why :math:`\tilde v` and not the design velocity :math:`v`: one specific force per
interval (three numbers) cannot carry both the velocity and the position increment (six)
of a path whose body-frame specific force changes inside the interval.  With
:math:`f^n = a - g^n + 2\,\omega_{ie}^n \times v` and :math:`f^b = C(q)^\top f^n`, the design
acceleration departs from the scheme's inside an interval by :math:`(s - \Delta t/2)\,
\delta` to first order, with

.. math::  \delta = C(q)\,\dot f^b - \omega_{ie}^n \times (2a + f^n)

(the body-frame specific force's rate; the Earth-rate terms are those the scheme holds
over an interval).  Readings that carry :math:`v` exactly leave each position increment
:math:`\delta\,\Delta t^3/12` off, a drift of :math:`\tfrac{\Delta t^2}{12}\int\delta\,dt`:
the trapezoid rule's error, 1.1e-5 m over the first 60 s of the bundled flight at
100 Hz.  The readings therefore carry :math:`\tilde v = v - \tfrac{\Delta t^2}{12}\,\delta`
(the Euler-Maclaurin end correction; the mechanisation starts from :math:`\tilde v_0`), and
the mechanised position equals the design path to :math:`O(\Delta t^4)`: 4e-11 m over
the same 60 s (3e-10 m on the tests' 9°/s turn), the whole 500 s flight within 1e-7 m
(the rounding of the mechanisation's 50 000-step sums).  :math:`\dot f^b` is a central
difference (:data:`FD_STEP_S`) of the analytic design.  The velocity offset is at most
5.3e-6 m/s on the bundled flight, far below any sensor's noise; the truth (position,
velocity, attitude) is the mechanisation of the readings, so it stays exactly
self-consistent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nav.quaternion import dcm_to_q, qconj, qrotate
from nav.strapdown import ideal_imu, mechanise
from slam.kinds.fixed_wing.world import FlightSpec

Array = NDArray[np.float64]
TWO_PI = 2.0 * math.pi
_GL_NODES = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)])
_GL_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 9.0
#: Half-step (s) of the central difference that gives the body-frame specific force's rate.
FD_STEP_S = 1e-4

__all__ = ["Trajectory", "commands", "design", "fly", "velocity_offset"]


@dataclass(frozen=True)
class Trajectory:
    """The truth at every IMU sample ``k = 0..K`` (``t = k dt``).

    p, v, q : mechanised position (ENU, m), velocity (m/s), ``q_nb`` (the truth; ``v``
    is the design velocity plus :func:`velocity_offset`);
    p_design : the design path (integral of the design velocity);
    gyro, accel : (K, 3) error-free interval readings (module docstring);
    turn_rate : (K + 1,) design heading rate (rad/s).
    """

    dt: float
    p: Array
    v: Array
    q: Array
    p_design: Array
    gyro: Array
    accel: Array
    turn_rate: Array

    @property
    def n_samples(self) -> int:
        return self.gyro.shape[0]


def _steps(t: Array, start: Array, ramp: Array) -> tuple[Array, Array, Array]:
    """Per time and manoeuvre (len(t), M): ``S(s)``, ``S'(s)/T`` and ``T J(s)``."""
    s = (t[:, None] - start[None]) / ramp[None]
    inside = (s > 0.0) & (s < 1.0)
    sc = np.clip(s, 0.0, 1.0)
    step = np.where(s >= 1.0, 1.0, np.where(inside, sc - np.sin(TWO_PI * sc) / TWO_PI, 0.0))
    rate = np.where(inside, (1.0 - np.cos(TWO_PI * sc)) / ramp[None], 0.0)
    J = np.where(s >= 1.0, s - 0.5,
                 np.where(inside, 0.5 * sc**2 + (np.cos(TWO_PI * sc) - 1.0) / TWO_PI**2, 0.0))
    return step, rate, J * ramp[None]


def commands(spec: FlightSpec, t: Array) -> dict[str, Array]:
    """Design ``V, dV, gamma, dgamma, psi, r`` at times ``t`` (module docstring)."""
    t = np.asarray(t, dtype=np.float64)
    start, ramp = np.asarray(spec.start_s), np.asarray(spec.ramp_s)
    step, rate, J = _steps(t, start, ramp)

    def deltas(first: float, targets: tuple[float, ...]) -> Array:
        return np.diff(np.concatenate([[first], targets]))

    dV = deltas(spec.start_speed_mps, spec.speed_mps)
    dg = deltas(spec.start_climb_rad, spec.climb_rad)
    dr = deltas(0.0, spec.turn_rate_rad_s)
    return {"V": spec.start_speed_mps + step @ dV, "dV": rate @ dV,
            "gamma": spec.start_climb_rad + step @ dg, "dgamma": rate @ dg,
            "psi": spec.start_heading_rad + J @ dr, "r": step @ dr}


def design(spec: FlightSpec, t: Array) -> tuple[Array, Array, Array]:
    """Design velocity ``v``, acceleration ``a`` (len(t), 3) and heading rate at ``t``."""
    c = commands(spec, t)
    V, g, psi, r = c["V"], c["gamma"], c["psi"], c["r"]
    cg, sg, cp, sp = np.cos(g), np.sin(g), np.cos(psi), np.sin(psi)
    u = np.column_stack([cg * cp, cg * sp, sg])
    du_dg = np.column_stack([-sg * cp, -sg * sp, cg])
    du_dp = np.column_stack([-cg * sp, cg * cp, np.zeros_like(g)])
    a = c["dV"][:, None] * u + V[:, None] * (c["dgamma"][:, None] * du_dg + r[:, None] * du_dp)
    return V[:, None] * u, a, r


def attitude(v: Array, a: Array, gravity: Array) -> Array:
    """Coordinated-flight ``q_nb`` (module docstring), sign-continuous along the rows."""
    x = v / np.linalg.norm(v, axis=1, keepdims=True)
    f = a - gravity
    z = f - np.sum(f * x, axis=1, keepdims=True) * x
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    q = dcm_to_q(np.stack([x, np.cross(z, x), z], axis=-1))
    flips = np.concatenate([[1.0], np.sign(np.sum(q[1:] * q[:-1], axis=1))])
    flips[flips == 0.0] = 1.0
    return q * np.cumprod(flips)[:, None]


def design_path(spec: FlightSpec, dt: float, n: int, p0: Array) -> Array:
    """Design positions at ``k dt``, ``k = 0..n``: Gauss-Legendre integral of ``v``."""
    mids = (np.arange(n) + 0.5) * dt
    nodes = (mids[:, None] + 0.5 * dt * _GL_NODES[None]).ravel()
    v, _, _ = design(spec, nodes)
    steps = np.einsum("kjc,j->kc", v.reshape(n, 3, 3), _GL_WEIGHTS) * (0.5 * dt)
    return np.vstack([p0, p0 + np.cumsum(steps, axis=0)])


def _specific_force_body(spec: FlightSpec, t: Array, gravity: Array,
                         earth_rate: Array | None) -> Array:
    """Design body-frame specific force ``C(q)^T (a - g + 2 w_ie x v)`` at ``t``."""
    v, a, _ = design(spec, t)
    f = a - gravity
    if earth_rate is not None:
        f = f + 2.0 * np.cross(earth_rate, v)
    return qrotate(qconj(attitude(v, a, gravity)), f)


def velocity_offset(spec: FlightSpec, t: Array, dt: float, gravity: Array,
                    earth_rate: Array | None = None) -> Array:
    r""":math:`\tilde v - v = -\tfrac{\Delta t^2}{12}\,\delta` at ``t`` (module docstring),
    (len(t), 3)."""
    t = np.asarray(t, dtype=np.float64)
    g = np.asarray(gravity, dtype=np.float64)
    wie = None if earth_rate is None or not np.any(earth_rate) else np.asarray(
        earth_rate, dtype=np.float64)
    v, a, _ = design(spec, t)
    q = attitude(v, a, g)
    f_rate = (_specific_force_body(spec, t + FD_STEP_S, g, wie)
              - _specific_force_body(spec, t - FD_STEP_S, g, wie)) / (2.0 * FD_STEP_S)
    delta = qrotate(q, f_rate)
    if wie is not None:
        delta = delta - np.cross(wie, 3.0 * a - g + 2.0 * np.cross(wie, v))
    return -(dt * dt / 12.0) * delta


def fly(spec: FlightSpec, duration_s: float, dt: float, height_m: float, gravity: Array,
        earth_rate: Array | None = None) -> Trajectory:
    """The truth trajectory of ``spec`` from ENU ``[0, 0, height_m]`` (module docstring)."""
    n = round(duration_s / dt)
    t = np.arange(n + 1) * dt
    g = np.asarray(gravity, dtype=np.float64)
    v, a, r = design(spec, t)
    q = attitude(v, a, g)
    v_imu = v + velocity_offset(spec, t, dt, g, earth_rate)
    gyro, accel = ideal_imu(v_imu, q, dt, g, earth_rate)
    p0 = np.array([0.0, 0.0, float(height_m)])
    P, Vt, Q = mechanise(p0[None], v_imu[:1], q[:1], gyro, accel, dt, g, earth_rate,
                         all_samples=True)
    return Trajectory(dt, P[0], Vt[0], Q[0], design_path(spec, dt, n, p0), gyro, accel, r)
