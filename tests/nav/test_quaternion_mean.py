"""[Ding 2017]: the eigenvector quaternion mean (:mod:`nav.quaternion_mean`).

* exact on symmetric sets, sign-blind, and agrees with the iterative chart mean on
  tight clouds; as a filter space with pseudo-observations, the HoMM-UKF converges.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Noise, Transition
from estimators.homm import HighOrderMoment
from estimators.sigma import SigmaPointFilter
from nav.pseudo_observation import (
    pseudo_observation_model,
)
from nav.quaternion import qexp, qmul, qnormalize, qto_dcm
from nav.quaternion_mean import EigenMeanQuaternion, eigen_mean
from nav.spaces import UnitQuaternion


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
