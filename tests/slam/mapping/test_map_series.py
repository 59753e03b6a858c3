"""Per-epoch map summaries (:mod:`slam.mapping.map_series`): landmark count, squared error,
NEES and covariance trace from a belief, the same for square-root and dense beliefs, NaN
instead of an exception on a bad block, and the filter loop's time leaving them out."""

from __future__ import annotations

import numpy as np

from estimators import Euclidean, Gaussian, SqrtGaussian
from slam.kinds.planar.slam import PLANAR_LAYOUT
from slam.mapping.map_series import MapRecorder, vehicle_variances


def _belief(n_lm: int, rng: np.random.Generator):
    n = 3 + 2 * n_lm
    S = np.tril(rng.normal(size=(n, n))) + 3.0 * np.eye(n)
    mean = rng.normal(size=n)
    return SqrtGaussian(mean, S, Euclidean(n)), Gaussian(mean, S @ S.T, Euclidean(n))


def test_map_summary_by_hand_for_sqrt_and_dense_beliefs():
    rng = np.random.default_rng(3)
    sq, dense = _belief(3, rng)
    truth = rng.normal(size=(5, 2))
    ids = [4, -1, 0]  # the middle landmark's true id is unknown (nearest neighbour)
    rec = MapRecorder(PLANAR_LAYOUT, 2, truth)
    rec.record(0, sq, ids)
    rec.record(1, dense, ids)
    m = rec.series()
    C = dense.cov
    err = sq.mean[3:].reshape(3, 2)[[0, 2]] - truth[[4, 0]]
    blocks = [C[3:5, 3:5], C[7:9, 7:9]]
    nees = sum(e @ np.linalg.solve(B, e) for e, B in zip(err, blocks))
    for e in (0, 1):
        assert (m.n[e], m.scored[e], m.nees_count[e]) == (3, 2, 2)
        np.testing.assert_allclose(m.sq_err[e], np.sum(err**2), rtol=1e-6)
        np.testing.assert_allclose(m.nees[e], nees, rtol=1e-5)
        np.testing.assert_allclose(m.trace[e], np.trace(C[3:, 3:]), rtol=1e-6)
    assert m.dof == 2 and m.n.dtype == np.float32
    np.testing.assert_allclose(vehicle_variances(sq, 3), np.diag(C)[:3], rtol=1e-12)
    np.testing.assert_allclose(vehicle_variances(dense, 3), np.diag(C)[:3], rtol=1e-12)


def test_no_truth_no_landmarks_and_bad_blocks():
    rng = np.random.default_rng(4)
    sq, _ = _belief(2, rng)
    rec = MapRecorder(PLANAR_LAYOUT, 4, None)
    rec.record(0, SqrtGaussian(sq.mean[:3], sq.sqrt[:3, :3], Euclidean(3)), [])
    rec.record(1, sq, [0, 1])
    bad = SqrtGaussian(sq.mean, np.full_like(sq.sqrt, np.nan), sq.space)
    with np.errstate(all="raise"):  # the filter loop raises on floating-point errors
        rec.record(2, bad, [0, 1])
    m = rec.series()
    assert (m.n[0], m.trace[0]) == (0, 0) and m.n[1] == 2 and np.isnan(m.sq_err[1])
    assert m.trace[1] > 0 and np.isnan(m.trace[2]) and np.isnan(m.n[3])  # never recorded
    assert rec.seconds > 0.0
