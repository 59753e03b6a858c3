"""Strapdown mechanisation (nav.strapdown) and the truth / IMU simulator (nav.imu_sim)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nav.euler import euler_zyx_to_q, q_to_euler_zyx
from nav.imu_errors import ImuErrors, corrupt_imu
from nav.quaternion import qconj, qexp, qlog, qmul, qrotate
from nav.strapdown import (
    SERIES_BELOW,
    attitudes,
    earth_rate_enu,
    gamma_coefficients,
    gamma_matrices,
    gravity_enu,
    ideal_imu,
    mechanise,
    prefix_products,
)
from nav.terrain import Terrain
from slam.kinds.drone.flight import FlightPlan, fly, steer

G = gravity_enu()


def helix(t: np.ndarray, R: float = 20.0, w: float = 0.3, climb: float = 0.5,
          bank: float = 0.2):
    """Constant turn (radius R, rate w) with constant climb and constant bank: position,
    velocity, acceleration, attitude (nose along the velocity's heading)."""
    c, s = np.cos(w * t), np.sin(w * t)
    p = np.stack([R * c, R * s, climb * t], axis=-1)
    v = np.stack([-R * w * s, R * w * c, np.full_like(t, climb)], axis=-1)
    a = np.stack([-R * w * w * c, -R * w * w * s, np.zeros_like(t)], axis=-1)
    q = euler_zyx_to_q(np.full_like(t, bank), np.zeros_like(t), w * t + np.pi / 2)
    return p, v, a, q


def test_mechanisation_reproduces_constant_turn_and_climb_to_1e6_m_over_10_s():
    dt, n = 0.01, 1000  # 10 s at 100 Hz, noise off
    t = np.arange(n + 1) * dt
    p, v, a, q = helix(t)
    # constant body-frame readings of this motion (closed form)
    omega_b = qrotate(qconj(q[0]), np.array([0.0, 0.0, 0.3]))
    f_b = qrotate(qconj(q[0]), a[0] - G)
    assert np.allclose(qrotate(qconj(q[n // 2]), a[n // 2] - G), f_b, atol=1e-12)
    P, V, Q = mechanise(p[:1], v[:1], q[:1], np.tile(omega_b, (n, 1)), np.tile(f_b, (n, 1)),
                        dt, G, all_samples=True)
    assert np.max(np.abs(P[0] - p)) < 1e-6
    assert np.max(np.abs(V[0] - v)) < 1e-9
    assert np.max(np.linalg.norm(qlog(qmul(qconj(Q[0]), q)), axis=1)) < 1e-12
    # end-state form agrees with the all-samples form
    pe, ve, qe = mechanise(p[:1], v[:1], q[:1], np.tile(omega_b, (n, 1)),
                           np.tile(f_b, (n, 1)), dt, G)
    assert np.allclose(pe[0], P[0, -1], atol=1e-9) and np.allclose(ve[0], V[0, -1])


def test_mechanisation_is_vectorised_over_points():
    rng = np.random.default_rng(3)
    m, n, dt = 5, 20, 0.01
    p, v = rng.standard_normal((m, 3)), rng.standard_normal((m, 3))
    q = qexp(rng.standard_normal((m, 3)))
    gyro = rng.standard_normal((m, n, 3)) * 0.5
    acc = rng.standard_normal((m, n, 3)) + [0.0, 0.0, 9.8]
    P, V, Q = mechanise(p, v, q, gyro, acc, dt, G)
    for i in range(m):
        Pi, Vi, Qi = mechanise(p[i:i + 1], v[i:i + 1], q[i:i + 1], gyro[i], acc[i], dt, G)
        assert np.allclose(P[i], Pi[0], atol=1e-13) and np.allclose(V[i], Vi[0], atol=1e-13)
        assert np.allclose(Q[i], Qi[0], atol=1e-14)
    # the attitude-only helper matches
    Qa = attitudes(q[0], gyro[0], dt)
    assert np.allclose(Qa[-1], Q[0], atol=1e-14)


def test_prefix_products_both_algorithms_agree_with_a_loop():
    rng = np.random.default_rng(0)
    for n in (7, 200):  # short: matrix loop; long: Hillis-Steele scan
        E = qexp(rng.standard_normal((2, n, 3)) * 0.05)
        q0 = qexp(rng.standard_normal((2, 3)))
        out = prefix_products(E, q0)
        ref = q0.copy()
        assert np.allclose(out[:, 0], q0)
        for k in range(n):
            ref = qmul(ref, E[:, k])
            assert np.allclose(out[:, k + 1], ref, atol=1e-13)


def test_gamma_series_matches_closed_form_and_integrals():
    a = np.array([SERIES_BELOW * 0.999, SERIES_BELOW * 1.001, 0.3, 1e-9])
    series = gamma_coefficients(a**2)
    # closed form evaluated directly
    t = a
    exact = ((1 - np.cos(t)) / t**2, (t - np.sin(t)) / t**3, (t - np.sin(t)) / t**3,
             (t**2 / 2 + np.cos(t) - 1) / t**4)
    for s_, e_ in zip(series, exact):
        assert np.allclose(s_[:3], e_[:3], rtol=1e-7)
    # Γ1 = ∫ Exp(sφ) ds, Γ2 = ∫∫ Exp(rφ) dr ds by quadrature
    phi = np.array([0.2, -0.4, 0.3])
    G1, G2 = gamma_matrices(phi)
    from nav.quaternion import rotvec_to_dcm

    s = (np.arange(4000) + 0.5) / 4000
    R = rotvec_to_dcm(s[:, None] * phi)
    assert np.allclose(G1, R.mean(axis=0), atol=1e-7)
    assert np.allclose(G2, ((1 - s)[:, None, None] * R).mean(axis=0), atol=1e-7)


@pytest.mark.parametrize("earth", [False, True])
def test_ideal_imu_makes_mechanisation_reproduce_a_sampled_trajectory(earth):
    dt, n = 0.01, 1500
    t = np.arange(n + 1) * dt
    # a wavy, accelerating path with a varying attitude
    p = np.stack([3 * t + np.sin(0.7 * t), 2 * np.sin(0.3 * t), 0.5 * np.cos(0.5 * t)], -1)
    v = np.stack([3 + 0.7 * np.cos(0.7 * t), 0.6 * np.cos(0.3 * t),
                  -0.25 * np.sin(0.5 * t)], -1)
    q = euler_zyx_to_q(0.1 * np.sin(t), 0.05 * np.cos(0.4 * t), 0.3 * t)
    wie = earth_rate_enu(math.radians(34.75)) if earth else None
    gyro, acc = ideal_imu(v, q, dt, G, wie)
    P, V, Q = mechanise(p[:1], v[:1], q[:1], gyro, acc, dt, G, wie, all_samples=True)
    assert np.max(np.linalg.norm(qlog(qmul(qconj(Q[0]), q)), axis=1)) < 1e-11
    assert np.max(np.abs(V[0] - v)) < 1e-9
    assert np.max(np.abs(P[0] - p)) < 1e-4  # trapezoidal in position: O(dt^3) per step


def test_earth_rate_keeps_a_body_at_rest_levelled():
    wie = earth_rate_enu(math.radians(45.0))
    q0 = euler_zyx_to_q(0.0, 0.0, 0.3)
    n, dt = 1000, 0.01
    w_b = qrotate(qconj(q0), wie)  # a gyro at rest senses the Earth's rotation
    Q = attitudes(q0, np.tile(w_b, (n, 1)), dt, wie)
    assert np.max(np.linalg.norm(qlog(qmul(qconj(Q), q0)), axis=1)) < 1e-12


def plan(**kw) -> FlightPlan:
    base = dict(waypoints=((30.0, 0.0), (30.0, 30.0), (0.0, 30.0), (0.0, 0.0)),
                start_xy=(0.0, 0.0), start_heading=0.0, speed=3.0,
                max_turn_rate=math.radians(25.0), max_turn_accel=math.radians(30.0),
                steer_gain=1.5, at_waypoint=1.0, loops=1, height_above_ground=5.0,
                altitude_smoothing_s=1.0, dt=0.01, drag_per_s=0.3)
    base.update(kw)
    return FlightPlan(**base)


def test_steering_reaches_every_waypoint_with_bounded_turn_rate_and_accel():
    pl = plan(loops=2)
    xy, psi, rate, ends = steer(pl)
    assert len(ends) == 2 and ends[-1] == len(xy) - 1
    assert np.hypot(*(xy[-1] - pl.waypoints[-1])) < pl.at_waypoint
    assert np.max(np.abs(rate)) <= pl.max_turn_rate + 1e-12
    assert np.max(np.abs(np.diff(rate))) <= pl.max_turn_accel * pl.dt + 1e-12
    with pytest.raises(ValueError, match="not reached"):
        steer(plan(waypoints=((0.5, 0.2), (30.0, 0.0))), max_duration_s=5.0)


def test_flight_over_hills_keeps_height_and_bounded_acceleration():
    ter = Terrain.hills((-20.0, 50.0, -20.0, 50.0), [[15.0, 0.0], [30.0, 15.0]], 5.0, 6.0,
                        spacing=1.0)
    tr = fly(plan(), ter.height, G)
    agl = tr.p[:, 2] - ter.height(tr.p[:, :2])
    assert abs(np.mean(agl) - 5.0) < 0.3 and np.min(agl) > 3.5
    acc = np.diff(tr.v, axis=0) / tr.dt
    assert np.max(np.linalg.norm(acc, axis=1)) < 3.0
    # multirotor attitude: nose-down against the drag, banked in the turns
    e = np.degrees(q_to_euler_zyx(tr.q))
    assert 3.0 < np.median(e[:, 1]) < 8.0 and np.max(np.abs(e[:, 0])) > 3.0
    # the truth IS the mechanisation of the error-free readings
    P, V, Q = mechanise(tr.p[:1], tr.v[:1], tr.q[:1], tr.gyro, tr.accel, tr.dt, G)
    assert np.allclose(P[0], tr.p[-1], atol=1e-9) and np.allclose(V[0], tr.v[-1], atol=1e-10)


def test_corrupt_imu_statistics_and_zero_scale():
    rng = np.random.default_rng(5)
    K, dt = 200_000, 0.01
    z = np.zeros((K, 3))
    e = ImuErrors(1e-3, 0.0, 2e-3, 0.02, 0.0, 3e-3)
    log = corrupt_imu(z, z, dt, e, rng)
    noise = log.gyro - log.bias_gyro[:-1]
    assert np.allclose(np.std(noise, axis=0), 2e-3 / math.sqrt(dt), rtol=0.02)
    assert np.allclose(log.bias_gyro, log.bias_gyro[0])  # no random walk asked for
    clean = corrupt_imu(z, z, dt, e, rng, scale=0.0)
    assert not np.any(clean.gyro) and not np.any(clean.accel)
