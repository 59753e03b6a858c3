"""[Ding 2017]'s mechanism: HoMM points placed with the moments of the predicted points.

* the paper's φ₁, φ₂ (eq. after 20) against a hand computation, for a skewed predicted set
  (a quadratic map): not the Gaussian values, and the next draw's points match them (mean,
  covariance, third and fourth moments along the factor's columns);
* for the rule's own (undistorted) points the estimate returns the rule's moments, for a
  Gaussian after a linear map it does not;
* the update carries the moments unchanged; a refused estimate (kurtosis <= skewness², no
  Cholesky factor) falls back to the stated moments, flagged and counted;
* on a linear-Gaussian model the predicted-moments filter is still the Kalman filter,
  although its kurtosis leaves 3 (only mean and covariance reach a linear model).
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Euclidean, Gaussian, Measurement, Noise, Transition, make_filter
from estimators.homm import HighOrderMoment, MomentGaussian, paper_moments
from estimators.sigma import SigmaPointFilter, draw, sigma_predict

PRED = HighOrderMoment(0.0, 3.0, moments="predicted")
M0 = np.array([0.4, -0.2])
P0 = np.array([[0.5, 0.1], [0.1, 0.3]])
Q = np.diag([0.01, 0.02])


def quadratic(X: np.ndarray, u: object = None) -> np.ndarray:
    return np.column_stack([X[:, 0] + 0.8 * X[:, 0] ** 2, X[:, 1] + 0.5 * X[:, 0] * X[:, 1]])


def _hand_moments(mean: np.ndarray, cov: np.ndarray, noise: np.ndarray) -> tuple[float, float]:
    """The paper's (s, k) = (√N φ₁, N φ₂) written out: Julier's points of the prior, through
    the map; W_j, Ψ_j (plus the additive Gaussian noise's fourth-moment share), normalised by
    the cubes and fourth powers of the predicted covariance's Cholesky factor."""
    n = mean.size
    S = np.linalg.cholesky(cov)
    X = np.vstack([mean, mean + np.sqrt(3.0) * S.T, mean - np.sqrt(3.0) * S.T])
    w = np.r_[1.0 - n / 3.0, np.full(2 * n, 1.0 / 6.0)]
    Y = quadratic(X)
    ybar = w @ Y
    D = Y - ybar
    Py = (w[:, None] * D).T @ D
    P = Py + noise
    Sp = np.linalg.cholesky(P)
    q = np.diag(noise)
    W = np.sum(w @ D**3)
    Psi = np.sum(w @ D**4 + 6.0 * np.diag(Py) * q + 3.0 * q**2)
    return float(W / np.sum(Sp**3)), float(Psi / np.sum(Sp**4))


def test_skewed_predicted_set_gives_non_gaussian_moments_and_the_next_points_match_them():
    prior = Gaussian(M0, P0, Euclidean(2))
    b = sigma_predict(PRED, "dense", prior, Transition(quadratic, Noise.from_cov(Q)))
    assert isinstance(b, MomentGaussian) and b.moments.fallback is None
    s, k = _hand_moments(M0, P0, Q)
    assert (b.moments.skewness, b.moments.kurtosis) == pytest.approx((s, k), rel=1e-10)
    assert abs(s) > 0.5 and abs(k - 3.0) > 0.3, (s, k)  # not the Gaussian's (0, 3)
    # the next draw (update or prediction) places its points with them
    X, _, dX, w = draw(PRED.for_draw(b), b)
    np.testing.assert_allclose(w @ X, b.mean, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose((w[:, None] * dX).T @ dX, b.cov, rtol=1e-12, atol=1e-14)
    xi = np.linalg.solve(np.linalg.cholesky(b.cov), dX.T).T  # along the factor's columns
    np.testing.assert_allclose(w @ xi**3, [s, s], rtol=1e-10)
    np.testing.assert_allclose(w @ xi**4, [k, k], rtol=1e-10)
    # a fixed Gaussian rule would have drawn (0, 3)
    Xg, _, dXg, wg = draw(HighOrderMoment(), b)
    xig = np.linalg.solve(np.linalg.cholesky(b.cov), dXg.T).T
    np.testing.assert_allclose(wg @ xig**4, [3.0, 3.0], rtol=1e-12)


def test_the_estimate_returns_the_rules_own_moments_and_not_after_a_linear_map():
    A = np.array([[2.0, 0.3, -0.4], [0.3, 1.0, 0.2], [-0.4, 0.2, 0.5]])
    rule = HighOrderMoment((0.4,) * 3, (4.0,) * 3)
    X, _, dX, w = draw(rule, Gaussian(np.zeros(3), A, Euclidean(3)))
    s, k, why = paper_moments(dX, w, A)
    assert why is None and (s, k) == pytest.approx((0.4, 4.0), rel=1e-12)
    # the Gaussian set after a rotation: symmetric, but the kurtosis is not 3
    c, sn = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    Xg, _, dXg, wg = draw(HighOrderMoment(), Gaussian(np.zeros(3), A, Euclidean(3)))
    s, k, why = paper_moments(dXg @ R.T, wg, R @ A @ R.T)
    assert why is None and abs(s) < 1e-12 and abs(k - 3.0) > 0.1, k


def test_the_update_carries_the_predicted_moments_unchanged():
    filt = SigmaPointFilter("hommukf", PRED, "dense")
    b = filt.predict(filt.init(M0, Euclidean(2), cov=P0), Transition(quadratic, Noise.from_cov(Q)))
    post, _ = filt.update(b, Measurement(lambda X: X[:, :1] ** 2, Noise.from_cov([[0.1]])),
                          np.array([0.5]))
    assert isinstance(post, MomentGaussian) and post.moments == b.moments
    assert not np.allclose(post.cov, b.cov)
    again = filt.predict(post, Transition(quadratic, Noise.from_cov(Q)))
    assert again.moments.predictions == 2 and again.moments.fallbacks == 0


def test_a_refused_estimate_falls_back_to_the_stated_moments_flagged_and_counted():
    # the second axis is minus the first: the predicted factor's cubes nearly cancel, the
    # averaged skewness is 3.3 and exceeds the square root of the kurtosis (3.8)
    def mirror(X: np.ndarray, u: object = None) -> np.ndarray:
        return np.column_stack([X[:, 0] + 0.3 * X[:, 0] ** 2, -X[:, 0] + 0.1 * X[:, 1]])

    prior = Gaussian(np.zeros(2), np.eye(2), Euclidean(2))
    tr = Transition(mirror, Noise.from_cov(1e-6 * np.eye(2)))
    b = sigma_predict(PRED, "dense", prior, tr)
    m = b.moments
    assert m.fallback is not None and "skewness" in m.fallback, m
    assert (m.skewness, m.kurtosis) == (0.0, 3.0) and m.fallbacks == 1 and m.predictions == 1
    assert m.estimate[1] <= m.estimate[0] ** 2
    b2 = sigma_predict(PRED, "dense", b, tr)
    assert b2.moments.predictions == 2 and b2.moments.fallbacks >= 1
    # no Cholesky factor of the predicted covariance: no estimate, a reason
    s, k, why = paper_moments(np.zeros((5, 2)), np.full(5, 0.2), np.zeros((2, 2)))
    assert np.isnan(s) and np.isnan(k) and "Cholesky" in why


def test_predicted_moments_are_a_named_setting_and_checked():
    assert make_filter("hommukf").rule.moments == "predicted"
    fixed = make_filter("hommukf", moments="fixed").rule
    assert fixed == HighOrderMoment() and fixed.for_draw(
        MomentGaussian(M0, P0, Euclidean(2), None)) is fixed
    with pytest.raises(ValueError, match="moments must be one of"):
        HighOrderMoment(moments="adaptive")
    with pytest.raises(ValueError, match="scalar"):
        HighOrderMoment((0.0, 0.0), 3.0, moments="predicted")
    with pytest.raises(ValueError, match="kurtosis > skewness"):
        HighOrderMoment(2.0, 3.0, moments="predicted")


def test_predicted_moments_filter_is_the_kalman_filter_on_a_linear_model():
    """Every valid (s, k) gives points with the exact mean and covariance, and a linear
    model uses nothing else: the filter is the Kalman filter to round-off although the
    kurtosis it matches leaves 3 (the paper's normalisation by the Cholesky factor's
    fourth powers drifts on a correlated covariance)."""
    from tests.linear_model import B, F, H, R, linear_models, simulate_linear
    from tests.linear_model import Q as QL

    us, zs = simulate_linear(120, seed=4)
    filt = SigmaPointFilter("hommukf", PRED, "dense")
    tr, me = linear_models()
    x, P = np.zeros(4), np.diag([1.0, 2.0, 0.5, 1.5])
    b = filt.init(x, Euclidean(4), cov=P)
    kurt = []
    for u, z in zip(us, zs):
        x, P = F @ x + B @ u, F @ P @ F.T + QL
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x, P = x + K @ (z - H @ x), (np.eye(4) - K @ H) @ P
        b = filt.predict(b, tr, u)
        kurt.append(b.moments.kurtosis)
        b, _ = filt.update(b, me, z)
        np.testing.assert_allclose(b.mean, x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.cov, P, rtol=1e-9, atol=1e-13)
    assert b.moments.fallbacks == 0
    assert max(abs(k - 3.0) for k in kurt) > 1.0, (min(kurt), max(kurt))
