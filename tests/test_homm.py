"""Seed 002: HoMM sigma points, the eigenvector quaternion mean, the pseudo-observation.

* the HoMM rule reproduces mean, covariance, third and fourth moments (Gaussian and
  given skewness/kurtosis), is Julier's κ = 3 − n set for a Gaussian, and its filter
  equals the Kalman filter on linear models (additive and eq. 22-23 augmented noise);
* the eigenvector mean is exact on symmetric sets, sign-blind, and agrees with the
  iterative chart mean on tight clouds;
* the pseudo-observation vanishes on the true attitude and its noise-separation
  covariance matches Monte Carlo.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Cubature, Euclidean, Gaussian, Measurement, Noise, Transition, Unscented
from estimators.filters import FILTER_NAMES, make_filter
from estimators.homm import HighOrderMoment, augmented_rule, standardised_moments
from estimators.sigma import SigmaPointFilter, draw, sigma_predict
from nav.pseudo_observation import (
    pseudo_observation_matrix,
    pseudo_observation_model,
    pseudo_observation_noise,
    xi_matrix,
)
from nav.quaternion import qexp, qmul, qnormalize, qto_dcm
from nav.quaternion_mean import EigenMeanQuaternion, eigen_mean
from nav.spaces import UnitQuaternion

MEAN = np.array([0.3, -1.2, 2.0, 0.7])
SIG = np.array([1.5, 0.4, 2.0, 0.8])


def _points(rule, mean, cov):
    X, _, _, w = draw(rule, Gaussian(mean, cov, Euclidean(mean.size)))
    return X, w


# --------------------------------------------------------------------------- HoMM rule
def test_homm_gaussian_mean_and_covariance():
    X, w = _points(HighOrderMoment(), MEAN, np.diag(SIG**2))
    np.testing.assert_allclose(w.sum(), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(w @ X, MEAN, rtol=1e-14, atol=1e-14)
    D = X - MEAN
    np.testing.assert_allclose((w[:, None] * D).T @ D, np.diag(SIG**2), rtol=1e-13, atol=1e-14)


def test_homm_gaussian_third_moments_vanish():
    X, w = _points(HighOrderMoment(), MEAN, np.diag(SIG**2))
    D = X - MEAN
    m3 = np.einsum("m,mi,mj,mk->ijk", w, D, D, D)  # every E[d_i d_j d_k]
    np.testing.assert_allclose(m3, 0.0, atol=1e-13)


def test_homm_gaussian_fourth_moments_per_axis():
    X, w = _points(HighOrderMoment(), MEAN, np.diag(SIG**2))
    m4 = w @ (X - MEAN) ** 4
    np.testing.assert_allclose(m4, 3.0 * SIG**4, rtol=1e-13)
    # a rule that only matches the covariance does not (cubature: E d⁴ = n σ⁴)
    Xc, wc = _points(Cubature(), MEAN, np.diag(SIG**2))
    assert not np.allclose(wc @ (Xc - MEAN) ** 4, 3.0 * SIG**4, rtol=1e-3)


def test_homm_full_covariance_matches_moments_along_the_factor_columns():
    A = np.array([[2.0, 0.3, -0.4, 0.1], [0.3, 1.0, 0.2, 0.0], [-0.4, 0.2, 0.5, 0.1],
                  [0.1, 0.0, 0.1, 0.9]])
    X, w = _points(HighOrderMoment(), MEAN, A)
    D = X - MEAN
    np.testing.assert_allclose((w[:, None] * D).T @ D, A, rtol=1e-13, atol=1e-14)
    xi = np.linalg.solve(np.linalg.cholesky(A), D.T).T
    np.testing.assert_allclose(w @ xi**3, 0.0, atol=1e-13)
    np.testing.assert_allclose(w @ xi**4, 3.0, rtol=1e-13)


def test_gaussian_homm_is_julier_unscented_set():
    for n in (1, 2, 3, 5):
        xi, w = HighOrderMoment().points(n)
        xu, wu = Unscented(alpha=1.0, beta=0.0, kappa=3.0 - n).points(n)
        np.testing.assert_allclose(xi, xu, rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(w, wu, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(w[0], 1.0 - n / 3.0, atol=1e-15)


# skewed / heavy-tailed marginals with known standardised moments
GAMMA_K = np.array([2.0, 5.0, 9.0])           # gamma(k): skew 2/√k, kurtosis 3 + 6/k
SKEWED = (tuple(2.0 / np.sqrt(GAMMA_K)) + (0.0,), tuple(3.0 + 6.0 / GAMMA_K) + (5.0,))  # + t(7)


def test_homm_given_skewness_and_kurtosis_are_reproduced():
    rule = HighOrderMoment(*SKEWED)
    X, w = _points(rule, MEAN, np.diag(SIG**2))
    D = X - MEAN
    np.testing.assert_allclose(w @ X, MEAN, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose((w[:, None] * D).T @ D, np.diag(SIG**2), rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(w @ D**3, np.array(SKEWED[0]) * SIG**3, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(w @ D**4, np.array(SKEWED[1]) * SIG**4, rtol=1e-12)
    # a Gaussian-moment rule gets the skewed ones wrong
    Xg, wg = _points(HighOrderMoment(), MEAN, np.diag(SIG**2))
    assert not np.allclose(wg @ (Xg - MEAN) ** 3, np.array(SKEWED[0]) * SIG**3, atol=1e-3)


def test_standardised_moments_estimate_feeds_the_rule():
    rng = np.random.default_rng(0)
    n = 400_000
    samples = np.column_stack([rng.gamma(k, size=n) for k in GAMMA_K]
                              + [rng.standard_t(7, size=n)])
    skew, kurt = standardised_moments(samples * SIG + MEAN)
    np.testing.assert_allclose(skew, SKEWED[0], atol=0.05)
    np.testing.assert_allclose(kurt, SKEWED[1], rtol=0.1)
    rule = HighOrderMoment(skew, kurt)
    xi, w = rule.points(4)
    np.testing.assert_allclose(w @ xi**3, skew, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(w @ xi**4, kurt, rtol=1e-12)


def test_homm_rejects_impossible_moments_and_wrong_dimension():
    with pytest.raises(ValueError, match="kurtosis > skewness"):
        HighOrderMoment(skewness=2.0, kurtosis=3.9).points(2)
    with pytest.raises(ValueError, match="axes"):
        HighOrderMoment(skewness=(0.0, 0.1), kurtosis=3.0).points(3)


def test_homm_is_exact_for_quartic_polynomials_without_cross_terms():
    """E[x2⁴ + x1³ - x2² x0] for x ~ N(m, diag σ²) in closed form; cubature is not exact."""
    m, s = MEAN, SIG  # n = 4: for n = 3 the Gaussian HoMM set *is* the cubature set

    def f(X):
        return X[:, 2] ** 4 + X[:, 1] ** 3 - X[:, 2] ** 2 * X[:, 0]

    exact = (m[2] ** 4 + 6 * m[2] ** 2 * s[2] ** 2 + 3 * s[2] ** 4
             + m[1] ** 3 + 3 * m[1] * s[1] ** 2 - (m[2] ** 2 + s[2] ** 2) * m[0])
    X, w = _points(HighOrderMoment(), m, np.diag(s**2))
    assert w @ f(X) == pytest.approx(exact, rel=1e-13)
    Xc, wc = _points(Cubature(), m, np.diag(s**2))
    assert wc @ f(Xc) != pytest.approx(exact, rel=1e-3)


# --------------------------------------------------------------------------- linear filters
Fm = np.array([[1.0, 0.1, 0.005, 0.0], [0.0, 1.0, 0.1, 0.0], [0.0, 0.0, 0.98, 0.0],
               [0.02, 0.0, 0.0, 0.95]])
Gw = np.array([[0.0, 0.0], [0.1, 0.0], [1.0, 0.2], [0.0, 1.0]])
Hm = np.array([[1.0, 0.0, 0.0, 0.5], [0.0, 0.0, 1.0, -1.0]])
Qw = np.diag([0.04, 0.01])
Rm = np.array([[0.3, 0.05], [0.05, 0.2]])


def _linear_run(n_steps: int, seed: int):
    rng = np.random.default_rng(seed)
    x, zs = np.array([1.0, -0.5, 0.3, 2.0]), []
    for _ in range(n_steps):
        x = Fm @ x + Gw @ rng.multivariate_normal(np.zeros(2), Qw)
        zs.append(Hm @ x + rng.multivariate_normal(np.zeros(2), Rm))
    return zs


def _kalman(x0, P0, zs):
    x, P, out = x0.copy(), P0.copy(), []
    for z in zs:
        x, P = Fm @ x, Fm @ P @ Fm.T + Gw @ Qw @ Gw.T
        S = Hm @ P @ Hm.T + Rm
        K = P @ Hm.T @ np.linalg.inv(S)
        x, P = x + K @ (z - Hm @ x), (np.eye(4) - K @ Hm) @ P
        out.append((x.copy(), P.copy()))
    return out


@pytest.mark.parametrize("noise", ["additive", "augmented-eq23", "augmented-matched"])
def test_hommukf_equals_kalman_on_linear_model(noise):
    zs = _linear_run(150, seed=2)
    x0, P0 = np.zeros(4), np.diag([1.0, 2.0, 0.5, 1.5])
    ref = _kalman(x0, P0, zs)
    me = Measurement(lambda X: X @ Hm.T, Noise.from_cov(Rm))
    filt = SigmaPointFilter("hommukf", HighOrderMoment(), "dense")
    if noise == "additive":
        tr = Transition(lambda X, u: X @ Fm.T, Noise.from_sqrt(Gw @ np.sqrt(Qw)))
        rule = filt.rule
    else:  # x' = F x + G w with the noise in the sigma points (eq. 22-23)
        tr = Transition(lambda X, u, W: X @ Fm.T + W @ Gw.T, Noise.from_cov(Qw), additive=False)
        rule = augmented_rule(4, 2) if noise == "augmented-eq23" else filt.rule
    b = filt.init(x0, Euclidean(4), cov=P0)
    for z, (xr, Pr) in zip(zs, ref):
        b = sigma_predict(rule, "dense", b, tr)
        b, _ = filt.update(b, me, z)
        np.testing.assert_allclose(b.mean, xr, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.cov, Pr, rtol=1e-9, atol=1e-13)


def test_augmented_rule_is_eq_22_23():
    n, m = 3, 2
    N = n + m
    xi, w = augmented_rule(n, m).points(N)
    np.testing.assert_allclose(np.abs(xi[1:n + 1, :n]), np.sqrt(3.0) * np.eye(n))
    np.testing.assert_allclose(xi[[1 + j for j in range(n, N)], n:],
                               np.sqrt(N) * np.eye(m), rtol=1e-15)  # +√N on the noise axes
    np.testing.assert_allclose(w[[1 + j for j in range(n, N)]], 1.0 / (2 * N), rtol=1e-15)
    np.testing.assert_allclose(w[0], 1.0 - n / 3.0 - m / N, rtol=1e-14)
    np.testing.assert_allclose((w[:, None] * xi).T @ xi, np.eye(N), atol=1e-14)
    with pytest.raises(ValueError):
        augmented_rule(n, m).points(n)


def test_hommukf_is_registered():
    assert "hommukf" in FILTER_NAMES
    f = make_filter("hommukf")
    assert isinstance(f.rule, HighOrderMoment) and f.form == "dense"


# --------------------------------------------------------------------------- quaternion mean
def _cloud(q0, spread, rng, m=13):
    d = rng.normal(size=(m, 3)) * spread + rng.normal(size=3) * spread  # off-centre
    w = rng.uniform(0.2, 1.0, m)
    return qmul(q0, qexp(d)), w / w.sum()


def test_eigen_mean_of_symmetric_sets_is_the_centre():
    rng = np.random.default_rng(4)
    q0 = qnormalize(rng.normal(size=4))
    d = 0.3 * np.vstack([np.zeros(3), np.eye(3), -np.eye(3)])
    pts = qmul(q0, qexp(d))
    for w0 in (1 / 7, -0.5):  # positive, and a negative centre weight (unscented-like)
        w = np.r_[w0, np.full(6, (1 - w0) / 6)]
        np.testing.assert_allclose(eigen_mean(pts, w), q0, atol=1e-14)


def test_eigen_mean_ignores_quaternion_signs():
    rng = np.random.default_rng(5)
    q0 = qnormalize(rng.normal(size=4))
    pts, w = _cloud(q0, 0.2, rng)
    ref = eigen_mean(pts, w)
    flips = np.where(rng.uniform(size=len(w)) < 0.5, -1.0, 1.0)
    flips[np.argmax(w)] = 1.0
    np.testing.assert_allclose(eigen_mean(pts * flips[:, None], w), ref, atol=1e-14)
    flips[np.argmax(w)] = -1.0  # the result takes the sign of the largest-weight point
    np.testing.assert_allclose(eigen_mean(pts * flips[:, None], w), -ref, atol=1e-14)
    # naive averaging of ambient coordinates is wrecked by the flips
    naive = qnormalize(w @ (pts * flips[:, None]))
    assert abs(abs(naive @ ref) - 1.0) > 1e-3


def test_eigen_mean_agrees_with_iterative_chart_mean_for_tight_clouds():
    """They differ at O(σ³): ~5e-13 rad at σ = 1e-4, ~5e-7 rad at σ = 1e-2."""
    rng = np.random.default_rng(6)
    U = UnitQuaternion()
    q0 = qnormalize(rng.normal(size=4))
    for _ in range(10):
        pts, w = _cloud(q0, 1e-4, rng)
        assert np.linalg.norm(U.local(U.mean(pts, w), eigen_mean(pts, w))) < 1e-9
    pts, w = _cloud(q0, 0.1, rng)
    assert np.linalg.norm(U.local(U.mean(pts, w), eigen_mean(pts, w))) > 1e-6


def test_eigen_mean_batches_and_rejects_ambiguous_sets():
    rng = np.random.default_rng(7)
    a, wa = _cloud(qnormalize(rng.normal(size=4)), 0.1, rng)
    b, wb = _cloud(qnormalize(rng.normal(size=4)), 0.1, rng)
    out = eigen_mean(np.stack([a, b]), np.stack([wa, wb]))
    np.testing.assert_allclose(out, np.stack([eigen_mean(a, wa), eigen_mean(b, wb)]),
                               atol=1e-15)
    q = qnormalize(rng.normal(size=4))
    opposite = np.stack([q, qmul(q, qexp([np.pi, 0.0, 0.0]))])  # 180° apart
    with pytest.raises(ArithmeticError, match="not unique"):
        eigen_mean(opposite, np.array([0.5, 0.5]))


def test_eigen_mean_space_in_a_filter_with_pseudo_observations():
    """Static attitude, two reference vectors: HoMM-UKF on EigenMeanQuaternion converges."""
    rng = np.random.default_rng(8)
    q_true = qnormalize(rng.normal(size=4))
    refs = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    sigma = 0.01
    space = EigenMeanQuaternion()
    assert space.retract(q_true, [0.1, 0.0, 0.0]) == pytest.approx(
        UnitQuaternion().retract(q_true, [0.1, 0.0, 0.0]))
    filt = SigmaPointFilter("hommukf", HighOrderMoment(), "dense")
    tr = Transition(lambda X, u: X, Noise.from_cov(1e-8 * np.eye(3)))
    b = filt.init(qmul(q_true, qexp(np.deg2rad([10.0, -8.0, 15.0]))), space,
                  cov=np.deg2rad(20.0) ** 2 * np.eye(3))
    for _ in range(30):
        b = filt.predict(b, tr)
        B = refs @ qto_dcm(q_true) + rng.normal(0.0, sigma, refs.shape)  # rows: Cᵀ R + μ
        me = pseudo_observation_model(B, refs, sigma, b.mean, b.cov)
        b, _ = filt.update(b, me, np.zeros(me.noise.dim))
    err = np.linalg.norm(space.local(q_true, b.mean))
    assert err < 3.0 * np.sqrt(np.trace(b.cov)) and err < 0.01


# --------------------------------------------------------------------------- pseudo-observation
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
