"""[Ding 2017]: the high-order moment-matching (HoMM) sigma points and the HoMM-UKF.

* the HoMM rule reproduces mean, covariance, third and fourth moments (Gaussian and
  given skewness/kurtosis), is Julier's κ = 3 − n set for a Gaussian, and its filter
  equals the Kalman filter on linear models (additive and eq. 22-23 augmented noise).

(The eigenvector quaternion mean and the pseudo-observation of the same seed are tested
in tests/nav/test_quaternion_mean.py and tests/nav/test_pseudo_observation.py.)
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Cubature, Euclidean, Gaussian, Measurement, Noise, Transition, Unscented
from estimators.filters import FILTER_NAMES, make_filter
from estimators.homm import HighOrderMoment, augmented_rule, standardised_moments
from estimators.sigma import SigmaPointFilter, draw, sigma_predict

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
