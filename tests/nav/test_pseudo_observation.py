"""[Ding 2017]: the quaternion pseudo-observation (:mod:`nav.pseudo_observation`).

* it vanishes on the true attitude and its noise-separation covariance matches Monte
  Carlo.
"""

from __future__ import annotations

import numpy as np

from nav.pseudo_observation import (
    pseudo_observation_matrix,
    pseudo_observation_model,
    pseudo_observation_noise,
    xi_matrix,
)
from nav.quaternion import qexp, qmul, qnormalize, qto_dcm


def test_pseudo_observation_vanishes_on_true_attitude():
    rng = np.random.default_rng(9)
    q = qnormalize(rng.normal(size=(20, 4)))
    R = rng.normal(size=(20, 3))
    B = np.einsum("kji,kj->ki", qto_dcm(q), R)  # body = C(q)ᵀ nav
    G = pseudo_observation_matrix(B, R)
    assert np.max(np.abs(np.einsum("kij,kj->ki", G, q))) < 1e-12
    # ... and not on a wrong one; G is skew with rank 2
    assert np.min(np.linalg.norm(np.einsum("kij,kj->ki", G, np.roll(q, 1, axis=0)),
                                 axis=1)) > 1e-3
    np.testing.assert_allclose(G, -np.swapaxes(G, 1, 2), atol=0)
    assert np.all(np.linalg.matrix_rank(G) == 2)
    # the noisy reading enters as ½ q ⊗ [0, μ]
    mu = rng.normal(size=3)
    np.testing.assert_allclose(pseudo_observation_matrix(B[0] + mu, R[0]) @ q[0],
                               0.5 * xi_matrix(q[0]) @ mu, atol=1e-14)


def _noise_samples(Q, Pmu, rng):
    M = rng.multivariate_normal(np.zeros(3), Pmu, size=len(Q))
    return -0.5 * qmul(Q, np.column_stack([np.zeros(len(Q)), M]))


def test_noise_separation_formula_matches_monte_carlo():
    rng = np.random.default_rng(10)
    q0 = qnormalize(rng.normal(size=4))
    Pmu = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, -0.02], [0.0, -0.02, 0.01]])
    Q = qnormalize(q0 + 0.35 * rng.normal(size=(100_000, 4)))  # a wide attitude cloud
    V = _noise_samples(Q, Pmu, rng)
    mc = np.cov(V.T, bias=True)
    formula = pseudo_observation_noise(Q.mean(axis=0), np.cov(Q.T, bias=True), Pmu)
    rel = np.linalg.norm(formula - mc) / np.linalg.norm(mc)
    assert rel < 0.05
    # the state-uncertainty term matters here: leaving it out misses by far more than 5 %
    without = pseudo_observation_noise(Q.mean(axis=0), None, Pmu)
    assert np.linalg.norm(without - mc) / np.linalg.norm(mc) > 0.1


def test_pseudo_observation_model_noise_at_prior_matches_monte_carlo():
    rng = np.random.default_rng(11)
    q0 = qnormalize(rng.normal(size=4))
    P = np.diag([0.15, 0.1, 0.2]) ** 2
    sigma = np.array([0.02, 0.05, 0.03])
    refs = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    me = pseudo_observation_model(refs @ qto_dcm(q0), refs, sigma, q0, P)
    assert me.noise.dim == 6
    n = 100_000
    Q = qmul(q0, qexp(rng.multivariate_normal(np.zeros(3), P, size=n)))
    T = xi_matrix(q0).T
    V = np.hstack([_noise_samples(Q, np.diag(sigma**2), rng) @ T.T for _ in refs])
    mc = np.cov(V.T, bias=True)
    assert np.linalg.norm(me.noise.cov - mc) / np.linalg.norm(mc) < 0.05
    # h is the projected G q: zero at the true attitude
    np.testing.assert_allclose(me.h(q0[None, :]), 0.0, atol=1e-15)
