"""The spinning gyro and its resolution through the roll ([Spin SR-CH∞KF] eq. 1-3,
:mod:`slam.kinds.spinning.gyro`) against a closed-form coning motion, the roll gradient
and the smoother's eq. 3 factor against finite differences, and the simulated log
resolved back to the truth."""

from __future__ import annotations

import math

import numpy as np

from slam.kinds.spinning import models as M
from slam.kinds.spinning.gyro import body_rates, magnetometer_roll, resolve, roll_gradient
from slam.kinds.spinning.simulate import sim_config, simulate
from slam.kinds.spinning.truth import Field, attitude_dcm, body_field
from tests.slam.kinds.spinning.helpers import tiny_world

DEG = math.pi / 180.0
FIELD = Field(50986.1, -48.17 * DEG, 2.32 * DEG)  # Table 1

# Coning: the axis at a fixed elevation ALPHA precesses about the vertical at OMEGA while
# the body spins at SPIN.  Its angular velocity is OMEGA e_up + SPIN x_body, so in the body
# frame (up = [sin a, cos a cos g, -cos a sin g] there):
#   w = [SPIN + OMEGA sin a, OMEGA cos a cos g, -OMEGA cos a sin g].
ALPHA = 0.4
PERP = 1.07 * DEG  # the transverse rate OMEGA cos(ALPHA): the blind area's 1.07 deg/s
OMEGA = PERP / math.cos(ALPHA)
SPIN = 2 * math.pi * 15.0  # 15 rev/s


def _coning(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    gamma = SPIN * t
    closed = np.column_stack([SPIN + OMEGA * math.sin(ALPHA) + 0 * t,
                              OMEGA * math.cos(ALPHA) * np.cos(gamma),
                              -OMEGA * math.cos(ALPHA) * np.sin(gamma)])
    return gamma, closed


def test_body_rates_of_a_coning_motion_are_the_closed_form() -> None:
    t = np.linspace(0.0, 2.0, 37)
    gamma, closed = _coning(t)
    a = np.full_like(t, ALPHA)
    w = body_rates(a, gamma, 0.0 * t, OMEGA + 0 * t, SPIN + 0 * t)
    assert np.allclose(w, closed, rtol=0, atol=1e-12)
    # and independently from the rotation matrices: skew(w) = C^T dC/dt
    h = 1e-7
    for k in range(0, len(t), 6):
        C0 = attitude_dcm(np.array(ALPHA), np.array(OMEGA * t[k]), np.array(gamma[k]))
        C1 = attitude_dcm(np.array(ALPHA), np.array(OMEGA * (t[k] + h)),
                          np.array(SPIN * (t[k] + h)))
        W = C0.T @ (C1 - C0) / h
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], closed[k], rtol=1e-5, atol=1e-6)


def test_resolving_with_a_roll_error_leaks_the_transverse_rate() -> None:
    t = np.linspace(0.0, 1.0, 11)
    gamma, closed = _coning(t)
    a = np.full_like(t, ALPHA)
    assert np.allclose(resolve(closed[:, 1:], a, gamma), [0.0, OMEGA], rtol=0, atol=1e-15)
    for delta in (7 * DEG, -30 * DEG, math.pi):
        rates = resolve(closed[:, 1:], a, gamma + delta)
        # the transverse rate vector turned by delta: a pitch leak PERP sin(delta)
        assert np.allclose(rates[:, 0], PERP * math.sin(delta), rtol=0, atol=1e-15)
        assert np.allclose(rates[:, 1], OMEGA * math.cos(delta), rtol=0, atol=1e-15)


def test_eq3_at_10_hz_follows_the_cone_and_a_7_degree_roll_error_drifts_2_4_degrees() -> None:
    """The roll turns 1.5 revolutions between samples: only the roll at the sample's own
    instant resolves it.  A constant 7° roll error over an 18 s blind area drifts the pitch
    by 1.07°/s × sin 7° × 18 s = 2.35° (the issue's 0.13°/s, 2.4°)."""
    dt, T = 0.1, 18.0
    t = np.arange(0.0, T, dt)
    gamma, closed = _coning(t)
    x = np.array([ALPHA, 0.0])
    for k in range(len(t)):
        x = x + dt * resolve(closed[k, 1:], x[0], gamma[k])
    assert np.allclose(x, [ALPHA, OMEGA * len(t) * dt], rtol=0, atol=1e-12)
    x = np.array([ALPHA, 0.0])
    for k in range(len(t)):
        x = x + dt * resolve(closed[k, 1:], x[0], gamma[k] + 7 * DEG)
    drift = PERP * math.sin(7 * DEG) * len(t) * dt  # the pitch leak is exactly constant
    assert abs(x[0] - ALPHA - drift) < 1e-12 and abs(drift / DEG - 2.35) < 0.005


def test_roll_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        a, b, g = rng.uniform(-1.2, 1.2), rng.uniform(-1.0, 1.0), rng.uniform(0, 2 * math.pi)
        mag = body_field(FIELD, np.array(a), np.array(b), np.array(g))
        x, h = np.array([a, b]), 1e-7
        num = [(magnetometer_roll(FIELD, x + h * e, mag) - magnetometer_roll(FIELD, x - h * e, mag))
               / (2 * h) for e in np.eye(2)]
        assert np.allclose(roll_gradient(FIELD, x, mag), num, rtol=1e-5, atol=1e-7)


def test_smoother_eq3_factor_jacobians_match_finite_differences() -> None:
    rng = np.random.default_rng(8)
    omega = np.array([0.02, -0.015])
    mag = body_field(FIELD, np.array(0.6), np.array(0.05), np.array(2.0))
    for _ in range(10):
        a, b = rng.uniform([-1.0, -0.5], [1.0, 0.5]), rng.uniform([-1.0, -0.5], [1.0, 0.5])
        _, Ja, Jb = M.between_error(FIELD, 0.1, omega, mag, a, b)
        h = 1e-7
        for J, which in ((Ja, 0), (Jb, 1)):
            num = np.zeros((2, 2))
            for i, e in enumerate(np.eye(2)):
                up = [a, b]
                down = [a, b]
                up[which], down[which] = up[which] + h * e, down[which] - h * e
                num[:, i] = (M.between_error(FIELD, 0.1, omega, mag, *up)[0]
                             - M.between_error(FIELD, 0.1, omega, mag, *down)[0]) / (2 * h)
            assert np.allclose(J, num, rtol=1e-5, atol=1e-7)


def test_a_noise_free_log_resolved_with_the_true_roll_is_the_truth() -> None:
    w = tiny_world(**{"truth_noise.magnetometer_factor": 0.0, "truth_noise.gyro_factor": 0.0,
                      "sample_interval_s": 0.1})
    log = simulate(sim_config(w), np.random.default_rng(0))
    rates = resolve(np.asarray(log.gyro), log.alpha[:-1], log.gamma[:-1])
    x = np.vstack([log.truth[:1], log.truth[0] + np.cumsum(log.dt * rates, axis=0)])
    assert np.abs(x - log.truth).max() < 1e-10
    # the samples spin with the body: far from the pitch/yaw rates themselves
    assert np.abs(np.asarray(log.gyro) - rates).max() > 0.5 * np.abs(rates).max()
    # dead reckoning with the magnetometer's roll (eq. 7-8 at its own estimate): the truth
    assert np.abs(M.dead_reckoning(log, log.truth[0], w.field) - log.truth).max() < 1e-9
