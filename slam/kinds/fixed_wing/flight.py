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

IMU and truth (as the drone, :mod:`slam.kinds.drone.flight`): :func:`nav.strapdown.
ideal_imu` gives the interval-average rates and specific forces, and the truth **is**
their mechanisation (:func:`nav.strapdown.mechanise`, flat-Earth local-level ENU frame at
the start, Earth rate optional).  Attitude and velocity equal the design at every sample
(round-off); the position follows the design path to :math:`O(\Delta t^2)` summed over
the flight (the body-frame jerk inside an interval is not held constant by the
mechanisation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nav.quaternion import dcm_to_q
from nav.strapdown import ideal_imu, mechanise
from slam.kinds.fixed_wing.world import FlightSpec

Array = NDArray[np.float64]
TWO_PI = 2.0 * math.pi
_GL_NODES = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)])
_GL_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 9.0

__all__ = ["Trajectory", "commands", "design", "fly"]


@dataclass(frozen=True)
class Trajectory:
    """The truth at every IMU sample ``k = 0..K`` (``t = k dt``).

    p, v, q : mechanised position (ENU, m), velocity (m/s), ``q_nb``;
    p_design : the design path (integral of the design velocity);
    gyro, accel : (K, 3) error-free readings of the intervals;
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


def fly(spec: FlightSpec, duration_s: float, dt: float, height_m: float, gravity: Array,
        earth_rate: Array | None = None) -> Trajectory:
    """The truth trajectory of ``spec`` from ENU ``[0, 0, height_m]`` (module docstring)."""
    n = round(duration_s / dt)
    t = np.arange(n + 1) * dt
    g = np.asarray(gravity, dtype=np.float64)
    v, a, r = design(spec, t)
    q = attitude(v, a, g)
    gyro, accel = ideal_imu(v, q, dt, g, earth_rate)
    p0 = np.array([0.0, 0.0, float(height_m)])
    P, Vt, Q = mechanise(p0[None], v[:1], q[:1], gyro, accel, dt, g, earth_rate,
                         all_samples=True)
    return Trajectory(dt, P[0], Vt[0], Q[0], design_path(spec, dt, n, p0), gyro, accel, r)
