"""The AQE model: its interval map against the exact quaternion and velocity errors of a
constructed case (large misalignment, a constant drift and bias), the quadratic rotation
against the DCM, and the misalignment readout's covariance against finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from nav.quaternion import qexp, qmul, qnormalize
from slam.kinds.alignment.models import (
    _AqeMap,
    _delta_q_moments,
    _propagate,
    misalignment_error,
    quadratic_dcm,
    quadratic_rotate,
    true_state,
)
from slam.kinds.alignment.simulate import simulate_alignment
from tests.slam.kinds.alignment.worlds import NO_ERRORS, alignment_world


def _constant_errors_world(**extra):
    """Constant drift and bias only (no white noise, no Markov): the truth's error state
    then follows the model exactly up to the first-order drift terms."""
    return alignment_world(2.0, **{**NO_ERRORS, "imu.gyro_bias_deg_s": 0.01,
                                   "imu.accel_bias_g": 1e-4, **extra})


def _steps(world, seed: int) -> np.ndarray:
    log = simulate_alignment(world, np.random.default_rng(seed))
    x = true_state(log)
    assert np.linalg.norm(x[0, :4]) > 0.2  # a 10/10/30 deg misalignment: far from small
    return np.array([_propagate(x[j:j + 1], j, log)[0] - x[j + 1]
                     for j in range(log.n_epochs - 1)])


def test_aqe_map_equals_the_exact_error_propagation() -> None:
    step = _steps(alignment_world(2.0, **NO_ERRORS), 2)
    assert np.max(np.abs(step[:, :4])) < 1e-11  # quaternion error
    assert np.max(np.abs(step[:, 4:7])) < 1e-10  # velocity error (m/s)
    # with a drift the map is first order in it (the right Jacobian taken as I inside
    # each 1 ms sample: |eps| T |w| dt / 2 ~ 3e-8 at the 10 Hz roll's peak rate)
    step = _steps(_constant_errors_world(), 2)
    assert np.max(np.abs(step[:, :4])) < 2e-8
    assert np.max(np.abs(step[:, 4:7])) < 5e-8  # g x that x T
    assert np.max(np.abs(step[:, 7:])) == 0.0


def test_aqe_map_is_linear_in_dq_for_fixed_drift() -> None:
    log = simulate_alignment(_constant_errors_world(), np.random.default_rng(4))
    x = true_state(log)[3]
    d = np.zeros(13)
    d[:4] = [0.01, -0.02, 0.03, 0.005]
    f = [_propagate(x + a * d, 3, log)[0][:4] for a in (0.0, 1.0, 2.0)]
    assert np.allclose(f[2] - f[1], f[1] - f[0], atol=1e-15)


def test_quadratic_rotation_is_the_unnormalised_dcm() -> None:
    rng = np.random.default_rng(0)
    Q, v = 1.3 * rng.standard_normal((20, 4)), rng.standard_normal((20, 3))
    assert np.allclose(quadratic_rotate(Q, v), (quadratic_dcm(Q) @ v[..., None])[..., 0],
                       atol=1e-12)


def test_prior_moments_of_the_quaternion_error() -> None:
    q = qnormalize(np.array([0.9, 0.1, -0.3, 0.2]))
    sigma = np.radians([10.0, 10.0, 30.0])
    mean, cov = _delta_q_moments(q, sigma)
    rng = np.random.default_rng(1)
    dq = q - qmul(qexp(rng.standard_normal((200_000, 3)) * sigma), q)
    assert np.allclose(mean, dq.mean(axis=0), atol=1.5e-3)  # 4 standard errors
    assert np.allclose(cov, np.cov(dq.T), atol=5e-4)


def test_misalignment_covariance_matches_finite_differences() -> None:
    rng = np.random.default_rng(7)
    q_hat = qnormalize(rng.standard_normal((1, 4)))
    dq = 0.2 * rng.standard_normal((1, 4))
    q_true = qnormalize(q_hat - dq)
    A = rng.standard_normal((4, 4)) * 1e-3
    P = (A @ A.T)[None]
    err, cov = misalignment_error(q_hat, dq, P, q_true)
    assert np.allclose(err, 0.0, atol=1e-12)
    L = np.linalg.cholesky(P[0])
    J = np.empty((3, 4))
    h = 1e-7
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        plus, _ = misalignment_error(q_hat, dq + e, P, q_true)
        minus, _ = misalignment_error(q_hat, dq - e, P, q_true)
        J[:, i] = (plus - minus)[0] / (2 * h)
    assert np.allclose(cov[0], J @ L @ L.T @ J.T, rtol=1e-5, atol=1e-14)


@pytest.mark.parametrize("normalised", [True, False])
def test_ekf_jacobian_matches_finite_differences(normalised: bool) -> None:
    log = simulate_alignment(_constant_errors_world(), np.random.default_rng(8))
    fmap = _AqeMap(log, normalised)
    x = true_state(log)[5] + 0.01 * np.random.default_rng(9).standard_normal(13) * np.r_[
        np.ones(7), 1e-2 * np.ones(6)]
    F = fmap.jacobian(x, 5)
    h = np.full(13, 1e-6)
    num = np.empty((13, 13))
    for i in range(13):
        e = np.zeros(13)
        e[i] = h[i]
        num[:, i] = (fmap(x + e, 5)[0] - fmap(x - e, 5)[0]) / (2 * h[i])
    assert np.allclose(F, num, rtol=1e-6, atol=1e-8)
