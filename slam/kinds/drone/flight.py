r"""Truth trajectories and IMU logs for a multirotor flying a waypoint loop over terrain.

The truth is built in four steps, all deterministic (no randomness until
:func:`corrupt_imu`):

1. **Horizontal path** (:func:`steer`): Bailey's waypoint-steering idea for a multirotor
   at constant ground speed ``V``.  At each IMU sample the commanded turn rate is
   ``steer_gain · wrap(bearing to the waypoint - heading)``, limited to
   ``±max_turn_rate``; the actual turn rate follows it with at most ``max_turn_accel``,
   so the heading rate is continuous and the lateral acceleration ``V·ψ̇`` bounded.
   Waypoints are ticked off within ``at_waypoint`` metres and the run ends when the last
   waypoint of the last lap is reached.
2. **Altitude**: ground height under the path plus ``height_above_ground``, smoothed by a
   Gaussian of σ = ``altitude_smoothing_s`` in time; its vertical speed and acceleration
   are the same filter's analytic derivatives (derivative-of-Gaussian kernels), so they
   are consistent with the smoothed altitude and bounded.
3. **Attitude** (a multirotor tilts its thrust axis): the thrust must supply
   :math:`a - g^n` plus the cancellation of a linear air drag :math:`-c_d v`, so the body
   z axis points along :math:`a - g^n + c_d v` (``drag_per_s`` = :math:`c_d`; at 3 m/s and
   0.3/s the drone flies nose-down by about 5°), the body x axis along the horizontal
   velocity (projected perpendicular to z), :math:`y = z \times x`.  The accelerometer
   still senses :math:`a - g^n` (thrust plus drag), which then has a forward component.
4. **IMU and truth**: :func:`nav.strapdown.ideal_imu` turns the sampled attitudes and
   velocities into body angular rates and specific forces (interval averages, i.e. the
   delta-angle / delta-velocity a real IMU outputs), and the truth **is** the
   mechanisation (:func:`nav.strapdown.mechanise`) of those readings from the initial
   state.  Attitude and velocity equal the design values at every sample (round-off);
   the position follows the design path to :math:`O(\Delta t^3)` per sample (well under a
   millimetre over a flight).  So a noise-free log mechanised by the filters' own
   strapdown reproduces the truth to round-off.

:func:`nav.imu_errors.corrupt_imu` adds the sensor errors.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter1d

from estimators import wrap_angle
from nav.quaternion import dcm_to_q
from nav.strapdown import ideal_imu, mechanise

Array = NDArray[np.float64]

__all__ = ["FlightPlan", "Trajectory", "fly", "steer"]


@dataclass(frozen=True)
class FlightPlan:
    """Everything that fixes the truth trajectory (SI units, radians).

    ``waypoints`` (M, 2) are flown in order, ``loops`` times, from ``start_xy`` with
    heading ``start_heading`` (counter-clockwise from east).  ``dt`` is the IMU period.
    """

    waypoints: tuple[tuple[float, float], ...]
    start_xy: tuple[float, float]
    start_heading: float
    speed: float
    max_turn_rate: float
    max_turn_accel: float
    steer_gain: float
    at_waypoint: float
    loops: int
    height_above_ground: float
    altitude_smoothing_s: float
    dt: float
    drag_per_s: float = 0.0


@dataclass(frozen=True)
class Trajectory:
    """The truth at every IMU sample ``k = 0..K`` (``t = k·dt``).

    p, v : (K + 1, 3) ENU position (m) and velocity (m/s); q : (K + 1, 4) ``q_nb``;
    gyro, accel : (K, 3) error-free IMU readings of the intervals (rad/s, m/s²);
    ground : (K + 1,) ground height under the design path; loop_end_steps : (loops,)
    the sample at which each lap ends.
    """

    dt: float
    p: Array
    v: Array
    q: Array
    gyro: Array
    accel: Array
    ground: Array
    loop_end_steps: NDArray[np.int64]

    @property
    def n_samples(self) -> int:
        """K, the number of IMU intervals."""
        return self.gyro.shape[0]


def steer(plan: FlightPlan, max_duration_s: float | None = None
          ) -> tuple[Array, Array, Array, NDArray[np.int64]]:
    """Fly the horizontal path; returns ``xy`` (K+1, 2), heading ``psi`` (K+1,), heading
    rate ``rate`` (K+1,) and the lap-end samples.

    Raises ``ValueError`` if a waypoint is not reached within the time budget (four
    times the polyline length at the planned speed).
    """
    wps = [tuple(map(float, w)) for w in plan.waypoints]
    n_wp = len(wps)
    dt, V = plan.dt, plan.speed
    rmax, amax, gain = plan.max_turn_rate, plan.max_turn_accel, plan.steer_gain
    reach2 = plan.at_waypoint**2
    pts = np.vstack([plan.start_xy, np.array(wps)])
    lap = float(np.hypot(*np.diff(np.vstack([pts[1:], pts[1:2]]), axis=0).T).sum())
    first = math.dist(plan.start_xy, wps[0])
    if max_duration_s is None:
        max_duration_s = 4.0 * (first + plan.loops * lap) / V + 60.0
    budget = int(max_duration_s / dt) + 1

    x, y = map(float, plan.start_xy)
    psi, r = float(plan.start_heading), 0.0
    xs, ys, psis, rates = [x], [y], [psi], [r]
    ends: list[int] = []
    iwp, laps_done = 0, 0
    wx, wy = wps[0]
    for k in range(budget):
        while (wx - x) ** 2 + (wy - y) ** 2 < reach2:
            iwp += 1
            if iwp == n_wp:
                ends.append(k)
                laps_done += 1
                if laps_done == plan.loops:
                    return (np.column_stack([xs, ys]), np.array(psis), np.array(rates),
                            np.array(ends, dtype=np.int64))
                iwp = 0
            wx, wy = wps[iwp]
        err = wrap_angle(math.atan2(wy - y, wx - x) - psi)
        cmd = max(-rmax, min(rmax, gain * err))
        acc = max(-amax, min(amax, (cmd - r) / dt))
        psi1 = psi + r * dt + 0.5 * acc * dt * dt
        pmid = psi + 0.5 * r * dt + 0.125 * acc * dt * dt
        # Simpson's rule for the displacement along the quadratic heading
        x += V * dt / 6.0 * (math.cos(psi) + 4.0 * math.cos(pmid) + math.cos(psi1))
        y += V * dt / 6.0 * (math.sin(psi) + 4.0 * math.sin(pmid) + math.sin(psi1))
        psi, r = psi1, r + acc * dt
        xs.append(x)
        ys.append(y)
        psis.append(psi)
        rates.append(r)
    raise ValueError(f"waypoint {iwp} {list(wps[iwp])} was not reached within "
                     f"{max_duration_s:.0f} s (inside the drone's turning circle?)")


def attitude_from_acceleration(a: Array, heading: Array, gravity: Array) -> Array:
    r"""Multirotor attitude ``q_nb``: body z along :math:`a - g^n`, body x towards
    ``heading`` (projected perpendicular to z); sign-continuous along the samples.

    ``a`` is the thrust acceleration direction source: pass :math:`a + c_d v` to tilt
    against a linear drag."""
    z = a - gravity
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    h = np.column_stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)])
    x = h - np.sum(h * z, axis=1, keepdims=True) * z
    x = x / np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    q = dcm_to_q(np.stack([x, y, z], axis=-1))
    flips = np.concatenate([[1.0], np.sign(np.sum(q[1:] * q[:-1], axis=1))])
    flips[flips == 0.0] = 1.0
    return q * np.cumprod(flips)[:, None]


def fly(plan: FlightPlan, ground: Callable[[Array], Array], gravity: Array,
        earth_rate: Array | None = None) -> Trajectory:
    """The truth trajectory of ``plan`` over the terrain ``ground(xy) -> z`` (module doc)."""
    dt = plan.dt
    xy, psi, rate, ends = steer(plan)
    g = np.asarray(gravity, dtype=np.float64)
    base = np.asarray(ground(xy), dtype=np.float64)
    if not np.all(np.isfinite(base)):
        k = int(np.flatnonzero(~np.isfinite(base))[0])
        raise ValueError(f"the path leaves the terrain at ({xy[k, 0]:.1f}, {xy[k, 1]:.1f}) m")
    z_ref = base + plan.height_above_ground
    sigma = plan.altitude_smoothing_s / dt
    if sigma > 0.0:
        z = gaussian_filter1d(z_ref, sigma, order=0, mode="nearest")
        vz = gaussian_filter1d(z_ref, sigma, order=1, mode="nearest") / dt
        az = gaussian_filter1d(z_ref, sigma, order=2, mode="nearest") / (dt * dt)
    else:
        z = z_ref
        vz = np.gradient(z_ref, dt)
        az = np.gradient(vz, dt)
    V = plan.speed
    c, s = np.cos(psi), np.sin(psi)
    v = np.column_stack([V * c, V * s, vz])
    a = np.column_stack([-V * rate * s, V * rate * c, az])
    q = attitude_from_acceleration(a + plan.drag_per_s * v, psi, g)
    gyro, accel = ideal_imu(v, q, dt, g, earth_rate)
    p0 = np.array([xy[0, 0], xy[0, 1], z[0]])
    P, Vt, Q = mechanise(p0[None], v[:1], q[:1], gyro, accel, dt, g, earth_rate,
                         all_samples=True)
    return Trajectory(dt, P[0], Vt[0], Q[0], gyro, accel, base, ends)
