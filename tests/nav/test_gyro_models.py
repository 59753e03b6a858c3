"""nav.gyro: bit-for-bit equal to frozen copies of the star-sensor kind's former private
versions for scalar densities; per-axis and full densities against the closed form and a
Van Loan integral."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from numpy.typing import ArrayLike
from scipy.linalg import expm

from estimators import Transition
from nav.gyro import (
    dead_reckoning,
    density_matrix,
    interval_noise,
    interval_transition,
    ordered_product,
    propagate_points,
)
from nav.quaternion import qexp, qmul, qnormalize

N, DT = 25, 0.02
Points = tuple[np.ndarray, np.ndarray]  # (states (m, 7), gyro samples (N, 3))
# (arw rad/sqrt(s), bias random walk rad/s/sqrt(s)): the star-sensor world's order of
# magnitude, a larger pair, and a zero bias random walk (the 1e-30 regularisation)
SCALARS = [(1.454441e-5, 9.696273e-8), (3e-3, 2e-4), (1e-4, 0.0)]




def same_bits(a: ArrayLike, b: ArrayLike) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return (a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b)
            and a.tobytes() == b.tobytes())


def unit_quats(rng: np.random.Generator, m: int) -> np.ndarray:
    q = rng.normal(size=(m, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@pytest.fixture
def points() -> Points:
    """13 states [q, b] (a 6-d cubature cloud's size) and N gyro samples."""
    rng = np.random.default_rng(20240611)
    X = np.hstack([unit_quats(rng, 13), rng.normal(scale=1e-3, size=(13, 3))])
    gyro = rng.normal(scale=0.05, size=(N, 3)) + np.array([0.0, -1.1e-3, 0.0])
    return X, gyro


# ------------------------------------------------------------ frozen reference copies
# The scenario's private functions as they were when nav.gyro was written, so the exact
# operation order stays pinned after the scenario is switched to nav.gyro.

def _ref_ordered_product(E: np.ndarray) -> np.ndarray:
    n = E.shape[-2]
    size = 1 << max(n - 1, 0).bit_length()
    if size != n:
        pad = np.zeros(E.shape[:-2] + (size - n, 4))
        pad[..., 0] = 1.0
        E = np.concatenate([E, pad], axis=-2)
    while E.shape[-2] > 1:
        E = qmul(E[..., 0::2, :], E[..., 1::2, :])
    return E[..., 0, :]


def _ref_propagate_points(X: np.ndarray, gyro: np.ndarray, dt: float) -> np.ndarray:
    q, b = X[:, :4], X[:, 4:]
    m, n = X.shape[0], gyro.shape[0]
    size = 1 << max(n - 1, 0).bit_length()
    E = np.zeros((m, size, 4))
    E[:, n:, 0] = 1.0
    E[:, :n] = qexp((gyro[None, :, :] - b[:, None, :]) * dt)
    out = np.empty_like(X)
    out[:, :4] = qnormalize(qmul(q, _ref_ordered_product(E)))
    out[:, 4:] = b
    return out


def _ref_interval_noise(T: float, arw: float, bias_rw: float) -> np.ndarray:
    ga, gb = arw**2, bias_rw**2
    I3 = np.eye(3)
    Q = np.zeros((6, 6))
    Q[:3, :3] = (ga * T + gb * T**3 / 3.0) * I3
    Q[:3, 3:] = Q[3:, :3] = -0.5 * gb * T**2 * I3
    Q[3:, 3:] = gb * T * I3
    return Q


def _ref_dead_reckoning(log: SimpleNamespace, x0: np.ndarray) -> np.ndarray:
    out = np.empty((log.n_star, 4))
    q = x0[None, :4]
    out[0] = q[0]
    for j in range(1, log.n_star):
        q = qnormalize(qmul(q, _ref_ordered_product(qexp(log.gyro_block(j - 1) * log.dt))[None]))
        out[j] = q[0]
    return out


# ------------------------------------------------------------ scalar densities: same bits

@pytest.mark.parametrize("n", [1, 7, 8, N])
def test_ordered_product_bits(n: int) -> None:
    E = qexp(np.random.default_rng(n).normal(scale=0.01, size=(13, n, 3)))
    assert same_bits(ordered_product(E), _ref_ordered_product(E))


def test_propagate_points_bits(points: Points) -> None:
    X, gyro = points
    assert same_bits(propagate_points(X, gyro, DT), _ref_propagate_points(X, gyro, DT))


@pytest.mark.parametrize("arw, bias_rw", SCALARS)
def test_interval_noise_bits(arw: float, bias_rw: float) -> None:
    for T in (N * DT, 0.1, 1.0):
        assert same_bits(interval_noise(T, arw, bias_rw), _ref_interval_noise(T, arw, bias_rw))


@pytest.mark.parametrize("arw, bias_rw", SCALARS)
def test_interval_transition_bits(points: Points, arw: float, bias_rw: float) -> None:
    X, gyro = points
    mine = interval_transition(N, DT, arw, bias_rw)
    assert isinstance(mine, Transition) and mine.additive and mine.jacobian is None
    assert mine.space is None
    assert same_bits(mine.f(X, gyro), _ref_propagate_points(X, gyro, DT))
    assert same_bits(mine.noise.cov, _ref_interval_noise(N * DT, arw, bias_rw)
                     + 1e-30 * np.eye(6))


def test_dead_reckoning_bits(points: Points) -> None:
    X, gyro = points
    blocks = gyro.reshape(5, 5, 3)  # 5 intervals of 5 samples
    log = SimpleNamespace(n_star=6, dt=DT, gyro_block=lambda j: blocks[j])
    x0 = X[0]
    mine = dead_reckoning(x0[:4], blocks, DT)
    assert mine.shape == (6, 4)
    assert same_bits(mine, _ref_dead_reckoning(log, x0))


# ------------------------------------------------------------ per-axis densities

def closed_form(T: float, Sg: np.ndarray, Sb: np.ndarray) -> np.ndarray:
    return np.block([[Sg * T + Sb * T**3 / 3.0, -Sb * T**2 / 2.0],
                     [-Sb * T**2 / 2.0, Sb * T]])


def van_loan(T: float, Sg: np.ndarray, Sb: np.ndarray) -> np.ndarray:
    """∫_0^T Φ(s) G Σ Gᵀ Φ(s)ᵀ ds for δθ' = -δb - n_g, δb' = n_b at zero rate."""
    A = np.block([[np.zeros((3, 3)), -np.eye(3)], [np.zeros((3, 6))]])
    W = np.block([[Sg, np.zeros((3, 3))], [np.zeros((3, 3)), Sb]])
    M = expm(np.block([[-A, W], [np.zeros((6, 6)), A.T]]) * T)
    Phi = M[6:, 6:].T
    return Phi @ M[:6, 6:]


def test_per_axis_noise_is_block_diagonal_closed_form() -> None:
    arw, brw = np.array([1e-4, 2e-4, 5e-4]), np.array([1e-6, 3e-6, 2e-5])
    T = N * DT
    Q = interval_noise(T, arw, brw)
    ga, gb = arw**2, brw**2
    for i in range(3):  # axis i couples only attitude i and bias i
        block = Q[np.ix_([i, 3 + i], [i, 3 + i])]
        expect = [[ga[i] * T + gb[i] * T**3 / 3.0, -gb[i] * T**2 / 2.0],
                  [-gb[i] * T**2 / 2.0, gb[i] * T]]
        np.testing.assert_allclose(block, expect, rtol=1e-14, atol=0.0)
    off = np.ones((6, 6), bool)
    for i in range(3):
        off[np.ix_([i, 3 + i], [i, 3 + i])] = False
    assert np.all(Q[off] == 0.0)
    np.testing.assert_allclose(Q, closed_form(T, np.diag(ga), np.diag(gb)), rtol=1e-14, atol=0)
    np.testing.assert_allclose(Q, van_loan(T, np.diag(ga), np.diag(gb)), rtol=1e-9,
                               atol=1e-12 * np.max(Q))


def test_full_density_matches_van_loan() -> None:
    rng = np.random.default_rng(7)
    Lg, Lb = rng.normal(size=(3, 3)) * 1e-3, rng.normal(size=(3, 3)) * 1e-5
    Sg, Sb = Lg @ Lg.T, Lb @ Lb.T
    for T in (DT, N * DT, 2.0):
        Q = interval_noise(T, Sg, Sb)
        np.testing.assert_allclose(Q, closed_form(T, Sg, Sb), rtol=1e-13, atol=0)
        np.testing.assert_allclose(Q, van_loan(T, Sg, Sb), rtol=1e-8, atol=1e-12 * np.max(Q))
        np.testing.assert_array_equal(Q, Q.T)


def test_scalar_vector_and_matrix_forms_agree() -> None:
    T = N * DT
    Q = interval_noise(T, 3e-4, 2e-6)
    assert same_bits(Q, interval_noise(T, np.full(3, 3e-4), [2e-6] * 3))
    np.testing.assert_allclose(Q, interval_noise(T, 9e-8 * np.eye(3), 4e-12 * np.eye(3)),
                               rtol=1e-15, atol=0)
    trans = interval_transition(N, DT, [1e-4, 2e-4, 3e-4], 1e-6)
    np.testing.assert_array_equal(trans.noise.cov, interval_noise(T, [1e-4, 2e-4, 3e-4], 1e-6)
                                  + 1e-30 * np.eye(6))


@pytest.mark.parametrize("bad", [-1.0, [1.0, -1.0, 1.0], [1.0, 2.0], np.ones((2, 2)),
                                 np.array([[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]),
                                 -np.eye(3)])
def test_density_matrix_rejects(bad: object) -> None:
    with pytest.raises(ValueError):
        density_matrix(bad)


# ------------------------------------------------------------ propagation behaviour

def test_constant_rate_matches_one_rotation() -> None:
    w, b = np.array([0.3, -0.2, 0.5]), np.array([0.01, 0.02, -0.03])
    q0 = unit_quats(np.random.default_rng(3), 1)[0]
    X = np.r_[q0, b][None]
    out = propagate_points(X, np.tile(w, (N, 1)), DT)
    np.testing.assert_allclose(out[0, :4], qmul(q0, qexp((w - b) * N * DT)), atol=1e-14)
    assert np.array_equal(out[0, 4:], b)


def test_dead_reckoning_with_bias_follows_propagate_points(points: Points) -> None:
    X, gyro = points
    b = np.array([1e-3, -2e-3, 5e-4])
    blocks = [gyro[:10], gyro[10:13], gyro[13:]]
    q = dead_reckoning(X[0, :4], blocks, DT, bias=b)
    x = np.r_[X[0, :4], b][None]
    for j, block in enumerate(blocks, start=1):
        x = propagate_points(x, block, DT)
        np.testing.assert_allclose(q[j], x[0, :4], rtol=0, atol=1e-15)
    # rows of a (N, 3) array are one-sample blocks
    per_sample = dead_reckoning(X[0, :4], gyro, DT)
    np.testing.assert_allclose(per_sample[-1], dead_reckoning(X[0, :4], [gyro], DT)[-1],
                               atol=1e-13)
