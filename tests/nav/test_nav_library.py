"""The public nav models against closed forms: gravity, datasheet units, bias processes,
per-sample strapdown, coarse alignment, GNSS measurements, the INS error transition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nav import gravity as grav
from nav.alignment import coarse_alignment, level, track_heading
from nav.euler import euler_zyx_to_q, q_to_euler_zyx
from nav.gnss import gnss_measurement
from nav.imu_noise import BiasProcess, datasheet_psd, per_sample_density
from nav.ins import LAYOUT, SPACE, InsModel, error_transition, propagate
from nav.quaternion import qconj, qexp, qrotate
from nav.strapdown import mechanise


def test_normal_gravity_equator_pole_and_somigliana_consistency():
    assert grav.normal_gravity(0.0) == pytest.approx(grav.GAMMA_E, abs=1e-12)
    assert grav.normal_gravity(math.pi / 2) == pytest.approx(grav.GAMMA_P, abs=1e-9)
    # TR8350.2's published derived constants k and m
    assert grav.K == pytest.approx(grav.B * grav.GAMMA_P / (grav.A * grav.GAMMA_E) - 1, abs=1e-11)
    assert grav.M == pytest.approx(0.00344978650684, abs=1e-13)
    lat = np.radians([10.0, 45.0, 80.0])
    s2 = np.sin(lat) ** 2
    expect = grav.GAMMA_E * (1 + grav.K * s2) / np.sqrt(1 - grav.E2 * s2)
    np.testing.assert_allclose(grav.normal_gravity(lat), expect, rtol=1e-15)


def test_normal_gravity_free_air_gradient():
    lat = math.radians(30.0)
    s2 = math.sin(lat) ** 2
    g0 = float(grav.normal_gravity(lat))
    slope = -2.0 * g0 / grav.A * (1.0 + grav.F + grav.M - 2.0 * grav.F * s2)
    h = 1000.0
    expect = g0 * (1.0 + slope / g0 * h + 3.0 * h * h / grav.A**2)
    assert grav.normal_gravity(lat, h) == pytest.approx(expect, rel=1e-15)
    assert -3.09e-6 < slope < -3.07e-6  # the familiar 0.3086 mGal/m
    assert grav.gravity_vector(lat, 0.0, "NED")[2] == pytest.approx(g0)
    assert grav.gravity_vector(lat, 0.0, "ENU")[2] == pytest.approx(-g0)
    with pytest.raises(ValueError):
        grav.gravity_vector(lat, 0.0, "XYZ")


def test_datasheet_units():
    psd = datasheet_psd(0.15, 0.06, gyro_bias_instability_deg_h=3.0, gyro_bias_time_s=300.0,
                        gyro_rate_random_walk_deg_h_sqrt_h=6.0, accel_bias_instability_mg=0.05,
                        accel_bias_time_s=100.0, accel_random_walk_mps2_sqrt_h=0.0006)
    assert psd.gyro_density == pytest.approx(0.15 * math.pi / 180.0 / 60.0, rel=1e-15)
    assert psd.accel_density == pytest.approx(0.001, rel=1e-15)
    assert psd.gyro_bias.markov_sigma == pytest.approx(3.0 * math.pi / 180 / 3600, rel=1e-15)
    assert psd.gyro_bias.walk_psd == pytest.approx((6.0 * math.pi / 180 / 3600 / 60) ** 2)
    assert psd.accel_bias.markov_sigma == pytest.approx(0.05e-3 * 9.80665, rel=1e-15)
    assert psd.accel_bias.walk_psd == pytest.approx(1e-10, rel=1e-12)
    # 1 deg/sqrt(h) over one hour of integration: a 1 deg angle sigma
    one = datasheet_psd(1.0, 0.0).gyro_density
    assert one * math.sqrt(3600.0) == pytest.approx(math.radians(1.0), rel=1e-15)
    assert per_sample_density(0.01, 0.0001) == pytest.approx(1.0)


def test_markov_bias_keeps_its_steady_variance_and_walk_grows_linearly():
    b = BiasProcess(markov_sigma=0.2, time_s=50.0)
    var = 0.04
    for dt in (0.01, 1.0, 7.0):
        var = b.decay(dt) ** 2 * var + b.discrete_variance(dt)
    assert var == pytest.approx(0.04, rel=1e-14)
    assert b.psd() == pytest.approx(2 * 0.04 / 50.0)
    assert b.steady_sigma() == 0.2
    w = BiasProcess(walk_psd=1e-6)
    assert w.decay(3.0) == 1.0 and w.rate() == 0.0
    assert sum(w.discrete_variance(0.5) for _ in range(8)) == pytest.approx(4e-6)
    assert w.steady_sigma() == math.inf


def test_mechanise_per_sample_intervals_split_a_reading_exactly():
    rng = np.random.default_rng(3)
    gyro = rng.normal(0, 0.3, (1, 3))
    accel = rng.normal(0, 2.0, (1, 3)) + [0, 0, 9.8]
    g = np.array([0, 0, -9.8])
    q0 = qexp(np.array([0.1, -0.2, 0.3]))
    one = mechanise(np.zeros(3), [1.0, 2.0, 0.0], q0, gyro, accel, 0.7, g)
    parts = np.array([0.1, 0.25, 0.35])
    split = mechanise(np.zeros(3), [1.0, 2.0, 0.0], q0, np.repeat(gyro, 3, 0),
                      np.repeat(accel, 3, 0), parts, g)
    for a, b in zip(one, split):
        np.testing.assert_allclose(a, b, atol=1e-13)


def test_mechanise_closed_forms_with_uneven_intervals():
    dt = np.array([0.01, 0.003, 0.02, 1.9, 0.0026, 0.01])
    T = dt.sum()
    g = np.array([0, 0, -9.81])
    # constant yaw rate, specific force cancelling gravity: q = Exp(w T), v = 0, p = 0
    w = np.array([0.0, 0.0, 0.4])
    p, v, q = mechanise(np.zeros(3), np.zeros(3), [1.0, 0, 0, 0], np.tile(w, (6, 1)),
                        np.tile([0, 0, 9.81], (6, 1)), dt, g)
    np.testing.assert_allclose(q[0], qexp(w * T), atol=1e-14)
    np.testing.assert_allclose(v[0], 0.0, atol=1e-13)
    # constant forward acceleration, no rotation: p = v0 T + a T^2 / 2
    p, v, q = mechanise(np.zeros(3), [2.0, 0, 0], [1.0, 0, 0, 0], np.zeros((6, 3)),
                        np.tile([0.5, 0, 9.81], (6, 1)), dt, g)
    np.testing.assert_allclose(p[0], [2.0 * T + 0.25 * T * T, 0, 0], atol=1e-12)
    np.testing.assert_allclose(v[0], [2.0 + 0.5 * T, 0, 0], atol=1e-13)
    with pytest.raises(ValueError, match="intervals"):
        mechanise(np.zeros(3), np.zeros(3), [1.0, 0, 0, 0], np.zeros((6, 3)),
                  np.zeros((6, 3)), dt[:3], g)


def test_coarse_alignment_recovers_roll_pitch_and_track_heading():
    rng = np.random.default_rng(1)
    for _ in range(20):
        roll, pitch, yaw = rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)
        q = euler_zyx_to_q(roll, pitch, yaw)
        f_b = qrotate(qconj(q), np.array([0.0, 0.0, 9.81]))
        r, p = level(f_b)
        assert (r, p) == pytest.approx((roll, pitch), abs=1e-12)
        step = np.array([math.cos(yaw), math.sin(yaw), 0.3]) * 5.0
        assert track_heading([1.0, 2.0, 0.0], np.array([1.0, 2.0, 0.0]) + step) == \
            pytest.approx(yaw, abs=1e-12)
        qa = coarse_alignment(f_b, np.zeros(3), step)
        np.testing.assert_allclose(q_to_euler_zyx(qa), [roll, pitch, yaw], atol=1e-12)
    with pytest.raises(ValueError, match="undefined"):
        track_heading([0, 0, 0], [0, 0, 5.0])


def _state(rng: np.random.Generator) -> np.ndarray:
    return np.concatenate([rng.normal(0, 10, 3), rng.normal(0, 5, 3),
                           qexp(rng.normal(0, 1, 3)), rng.normal(0, 1e-3, 3),
                           rng.normal(0, 0.05, 3)])


def _numeric_jacobian(fun, x: np.ndarray, d: int, eps: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(d):
        e = np.zeros(d)
        e[i] = eps
        up = fun(SPACE.retract(x[None], e[None])[0])
        dn = fun(SPACE.retract(x[None], -e[None])[0])
        cols.append((up - dn) / (2 * eps))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("parts", [("p",), ("v",), ("p", "v")])
def test_gnss_measurement_jacobians_with_a_lever_arm(parts):
    rng = np.random.default_rng(5)
    x = _state(rng)
    kw = {"lever_arm": [0.5, -0.2, 1.1], "body_rate": [0.1, -0.3, 0.2]}
    if "p" in parts:
        kw["position_sigma"] = 0.5
    if "v" in parts:
        kw["velocity_sigma"] = [0.1, 0.1, 0.2]
    meas = gnss_measurement(LAYOUT, **kw)
    H = meas.jacobian(x)
    Hn = _numeric_jacobian(lambda y: meas.h(y[None])[0], x, 15)
    np.testing.assert_allclose(H, Hn, atol=1e-7)
    plain = gnss_measurement(LAYOUT, position_sigma=1.0, velocity_sigma=0.1)
    np.testing.assert_array_equal(plain.h(x[None])[0], x[:6])
    with pytest.raises(ValueError):
        gnss_measurement(LAYOUT)


def test_ins_error_transition_matches_the_mechanisation():
    """Φ of the error model equals the numerical Jacobian of the mechanisation over an
    epoch of uneven intervals (to the first-order accuracy of the block discretisation)."""
    rng = np.random.default_rng(7)
    n = 37
    dt = rng.uniform(0.003, 0.02, n)
    gyro = rng.normal(0, 0.2, (n, 3))
    accel = rng.normal(0, 1.0, (n, 3)) + [0, 0, 9.81]
    psd = datasheet_psd(0.2, 0.05, gyro_bias_instability_deg_h=10.0, gyro_bias_time_s=60.0,
                        accel_random_walk_mps2_sqrt_h=0.01)
    model = InsModel(psd, np.array([0, 0, -9.81]))
    x = _state(rng)
    Phi, Qe = error_transition(x, gyro, accel, dt, model)
    y0 = propagate(x[None], gyro, accel, dt, model)[0]
    num = _numeric_jacobian(
        lambda y: SPACE.local(y0[None], propagate(y[None], gyro, accel, dt, model))[0], x, 15)
    np.testing.assert_allclose(Phi, num, atol=2e-3 * np.abs(num).max())
    assert np.all(np.linalg.eigvalsh(Qe) >= -1e-18)
    tau = dt.sum()
    # the position-velocity-attitude blocks' white-noise parts, to leading order in tau
    assert Qe[3, 3] == pytest.approx(psd.accel_density**2 * tau, rel=0.05)
    assert Qe[9, 9] == pytest.approx(psd.gyro_bias.discrete_variance(tau), rel=1e-3)


def test_preintegrated_propagation_is_the_mechanisation_at_the_mean_bias():
    from nav.ins import preintegrate, propagate_preintegrated

    rng = np.random.default_rng(11)
    n = 64
    dt = rng.uniform(0.003, 0.02, n)
    gyro = rng.normal(0, 0.3, (n, 3))
    accel = rng.normal(0, 1.0, (n, 3)) + [0, 0, 9.81]
    psd = datasheet_psd(0.2, 0.05, gyro_bias_instability_deg_h=10.0, gyro_bias_time_s=60.0,
                        accel_random_walk_mps2_sqrt_h=0.01)
    model = InsModel(psd, np.array([0, 0, -9.81]))
    X = np.stack([_state(rng) for _ in range(5)])
    X[1:, 10:] = X[0, 10:]  # points 0-4 share the biases
    dg = psd.gyro_bias.decay(dt.sum())
    pre = preintegrate(gyro, accel, dt, np.concatenate([X[0, 10:13] * np.sqrt(dg),
                                                        X[0, 13:16]]))
    exact = propagate(X, gyro, accel, dt, model)
    fast = propagate_preintegrated(X, pre, model)
    np.testing.assert_allclose(SPACE.local(exact, fast), 0.0, atol=1e-9)
    # points whose biases differ: the error is second order in the gyro-bias difference
    def err(d_gyro: float) -> float:
        Y = X.copy()
        Y[:, 10:13] += d_gyro
        Y[:, 13:16] += 0.05  # the specific force enters linearly: exact
        return float(np.abs(SPACE.local(propagate(Y, gyro, accel, dt, model),
                                        propagate_preintegrated(Y, pre, model))).max())

    big, small = err(1e-2), err(1e-3)
    assert small < 2e-6 and small < 0.1 * big


def test_preintegrated_bias_jacobians_match_finite_differences():
    from nav.ins import preintegrate
    from nav.quaternion import qconj, qlog, qmul

    rng = np.random.default_rng(12)
    n = 100
    dt = rng.uniform(0.005, 0.015, n)
    gyro = rng.normal(0, 0.3, (n, 3))
    accel = rng.normal(0, 1.0, (n, 3)) + [0, 0, 9.81]
    b = np.concatenate([rng.normal(0, 1e-3, 3), rng.normal(0, 0.05, 3)])
    pre = preintegrate(gyro, accel, dt, b)
    num = np.empty((9, 6))
    for i, step in enumerate([1e-6] * 3 + [1e-4] * 3):
        e = np.zeros(6)
        e[i] = step
        up, dn = preintegrate(gyro, accel, dt, b + e), preintegrate(gyro, accel, dt, b - e)
        num[0:3, i] = (qlog(qmul(qconj(dn.dq), up.dq))) / (2 * step)
        num[3:6, i] = (up.dv - dn.dv) / (2 * step)
        num[6:9, i] = (up.dp - dn.dp) / (2 * step)
    # the Gamma series to their first terms: second order in the interval
    np.testing.assert_allclose(pre.J, num, atol=1e-4 * np.abs(num).max())
    np.testing.assert_allclose(pre.J[:, 3:], num[:, 3:], atol=1e-6)  # linear in b_a


def _preintegrate_by_samples(gyro, accel, dt, b):
    """``preintegrate``'s increments and Jacobians by its docstring's per-sample sums, one
    sample at a time (quaternion attitudes; the reference of the closed sums)."""
    from nav.quaternion import qmul, qnormalize, qto_dcm, skew
    from nav.strapdown import gamma_coefficients

    q, v, p = np.array([1.0, 0, 0, 0]), np.zeros(3), np.zeros(3)
    S, Jvg, Jva, Jpg, Jpa, T = (np.zeros((3, 3)) for _ in range(6))
    eye = np.eye(3)
    for k in range(len(dt)):
        h = dt[k]
        phi, f = (gyro[k] - b[:3]) * h, accel[k] - b[3:]
        a1, b1, a2, b2 = (float(c) for c in gamma_coefficients(phi @ phi))
        K = skew(phi)
        G1, G2 = eye + a1 * K + b1 * K @ K, 0.5 * eye + a2 * K + b2 * K @ K
        Jr = eye - a1 * K + b1 * K @ K
        R = qto_dcm(q)
        u, wv = R @ G1 @ f, R @ G2 @ f
        p = p + v * h + wv * h * h
        v = v + u * h
        q = qnormalize(qmul(q, qexp(phi)))
        Fk = skew(f)
        jvg = (skew(u) @ S + 0.5 * R @ Fk * h) * h
        jva = -R @ G1 * h
        Jpg = Jpg + Jvg * h + (skew(wv) @ S + R @ Fk * h / 6.0) * h * h
        Jpa = Jpa + Jva * h - R @ G2 * h * h
        Jvg, Jva = Jvg + jvg, Jva + jva
        T = qto_dcm(q) @ Jr * h
        S = S + T
    J = np.zeros((9, 6))
    J[0:3, 0:3] = -qto_dcm(q).T @ S
    J[3:6, 0:3], J[3:6, 3:6], J[6:9, 0:3], J[6:9, 3:6] = Jvg, Jva, Jpg, Jpa
    return q, v, p, J


@pytest.mark.parametrize("spin", [0.3, 6.0])
def test_preintegration_equals_its_per_sample_sums(spin):
    from nav.ins import preintegrate
    from nav.quaternion import qto_dcm

    rng = np.random.default_rng(3)
    n = 57
    dt = rng.uniform(0.005, 0.015, n)
    gyro = rng.normal(0, spin, (n, 3))
    accel = rng.normal(0, 1.0, (n, 3)) + [0, 0, 9.81]
    b = np.concatenate([rng.normal(0, 1e-3, 3), rng.normal(0, 0.05, 3)])
    pre = preintegrate(gyro, accel, dt, b)
    q, v, p, J = _preintegrate_by_samples(gyro, accel, dt, b)
    np.testing.assert_allclose(pre.dq * np.sign(pre.dq[0]), q * np.sign(q[0]), atol=1e-14)
    np.testing.assert_allclose(pre.dv, v, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(pre.dp, p, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(pre.J, J, rtol=1e-11, atol=1e-14 * np.abs(J).max())
    np.testing.assert_allclose(pre.R_samples[-1], qto_dcm(q), atol=1e-14)
    np.testing.assert_allclose(pre.R_samples[0], np.eye(3))
