"""Point rules: exactness, and angle spaces across the ±π wrap."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from estimators import (
    Angle,
    CentralDifference,
    Cubature,
    Euclidean,
    Measurement,
    Noise,
    Product,
    Transition,
    Unscented,
    make_filter,
    wrap_angle,
)

MEAN = np.array([0.3, -1.2, 2.0])
COV = np.array([[2.0, 0.3, -0.4], [0.3, 1.0, 0.2], [-0.4, 0.2, 0.5]])


def gaussian_moment(idx: tuple[int, ...]) -> float:
    """E[prod x_i] for x ~ N(MEAN, COV), degree <= 3 (Isserlis with a mean)."""
    m, P = MEAN, COV
    if len(idx) == 0:
        return 1.0
    if len(idx) == 1:
        return m[idx[0]]
    if len(idx) == 2:
        i, j = idx
        return P[i, j] + m[i] * m[j]
    i, j, k = idx
    return m[i] * m[j] * m[k] + m[i] * P[j, k] + m[j] * P[i, k] + m[k] * P[i, j]


def rule_expectation(rule, idx):
    xi, wm = rule.points(3)
    X = MEAN + xi @ np.linalg.cholesky(COV).T
    return float(wm @ np.prod(X[:, list(idx)], axis=1)) if idx else float(wm.sum())


@pytest.mark.parametrize("rule", [Cubature(), Unscented(1.0, 0.0, 0.0), CentralDifference()])
def test_rules_integrate_polynomials_up_to_degree_three_exactly(rule):
    monomials = [()] + [c for d in (1, 2, 3)
                        for c in itertools.combinations_with_replacement(range(3), d)]
    for idx in monomials:
        assert rule_expectation(rule, idx) == pytest.approx(gaussian_moment(idx), abs=1e-12)


def test_cubature_is_not_exact_at_degree_four():
    # E[x^4] = 3 sigma^4 for a centred Gaussian; the 2n-point rule gives n sigma^4
    xi, w = Cubature().points(2)
    assert float(w @ xi[:, 0] ** 4) == pytest.approx(2.0)


def _heading_problem(offset: float):
    """Heading + rate, measured heading; the whole problem rotated by ``offset``."""
    dt = 0.1
    tr = Transition(lambda X, u: np.column_stack([wrap_angle(X[:, 0] + dt * X[:, 1]),
                                                  X[:, 1]]),
                    Noise.from_cov(np.diag([1e-4, 1e-4])))
    me = Measurement(lambda X: X[:, :1], Noise.from_cov([[0.05**2]]), space=Angle())
    rng = np.random.default_rng(7)
    truth = np.array([np.pi - 0.3 + offset, 0.5])  # crosses ±π after ~6 steps
    zs = []
    for _ in range(60):
        truth = np.array([wrap_angle(truth[0] + dt * truth[1]), truth[1]])
        zs.append(np.array([wrap_angle(truth[0] + 0.05 * rng.standard_normal())]))
    return tr, me, zs, np.array([wrap_angle(np.pi - 0.25 + offset), 0.4])


@pytest.mark.parametrize("name", ["ukf", "ckf", "srckf", "srukf", "srcdkf", "ekf"])
def test_heading_filter_across_the_wrap_matches_a_run_away_from_it(name):
    space = Product([Angle(), Euclidean(1)])
    results = []
    for offset in (0.0, -np.pi / 2):
        tr, me, zs, x0 = _heading_problem(offset)
        f = make_filter(name)
        b = f.init(x0, space, cov=np.diag([0.2, 0.1]))
        headings = []
        for z in zs:
            b, _ = f.update(f.predict(b, tr), me, z)
            headings.append(b.mean[0])
        results.append((np.array(headings), b.cov))
    crossed = np.abs(np.diff(results[0][0])).max() > np.pi  # the estimate really wrapped
    assert crossed
    np.testing.assert_allclose(wrap_angle(results[0][0] - np.pi / 2 - results[1][0]), 0.0,
                               atol=1e-9)
    np.testing.assert_allclose(results[0][1], results[1][1], rtol=1e-8, atol=1e-14)


def _max_predicted_heading_sigma(space, me):
    tr, _, zs, x0 = _heading_problem(0.0)
    f = make_filter("ukf")
    b = f.init(x0, space, cov=np.diag([0.2, 0.1]))
    worst = 0.0
    for z in zs:
        pred = f.predict(b, tr)
        worst = max(worst, float(np.sqrt(pred.cov[0, 0])))
        b, _ = f.update(pred, me, z)
    return worst


def test_euclidean_heading_filter_would_fail_across_the_wrap():
    """Treated as a plain number, the heading's sigma points split across ±π and the
    predicted covariance explodes at the crossing; on the angle space it does not."""
    _, me, _, _ = _heading_problem(0.0)
    flat = _max_predicted_heading_sigma(Euclidean(2), Measurement(me.h, me.noise))
    wrapped = _max_predicted_heading_sigma(Product([Angle(), Euclidean(1)]), me)
    assert wrapped < 0.5
    assert flat > 2.0
