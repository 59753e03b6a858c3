"""Strapdown mechanisation (:mod:`nav.strapdown`): closed-form motions, vectorisation, the
prefix products, the Γ series, ideal IMU readings, the Earth rate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nav.euler import euler_zyx_to_q
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
