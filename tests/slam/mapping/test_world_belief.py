"""The world-frame view of a group-error belief (:func:`slam.mapping.problem.world_belief`)."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Gaussian, SqrtGaussian, Wrapped
from estimators.slam_group import SlamGroup
from slam.mapping.problem import world_belief


def _m(G: SlamGroup, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    W = Wrapped(G.dim, (2,))
    steps = eps * np.eye(G.dim)
    return (W.local(x, G.retract(x, steps)) - W.local(x, G.retract(x, -steps))).T / (2 * eps)


@pytest.mark.parametrize("side", ["right", "left"])
def test_world_covariance_is_m_p_mt_in_both_forms(side):
    rng = np.random.default_rng(4)
    G = SlamGroup(3, side)
    x = rng.normal(size=9) * 20
    S = np.tril(rng.normal(size=(9, 9)))
    M = _m(G, x)
    want = M @ S @ S.T @ M.T
    ws, wd = world_belief(SqrtGaussian(x, S, G)), world_belief(Gaussian(x, S @ S.T, G))
    assert np.allclose(ws.cov, want, atol=1e-6 * np.abs(want).max())
    assert np.allclose(wd.cov, want, atol=1e-6 * np.abs(want).max())
    assert np.array_equal(ws.mean, x) and S.sum() == np.tril(S).sum()   # inputs untouched


def test_a_standard_belief_is_returned_as_is():
    b = Gaussian(np.zeros(5), np.eye(5), Wrapped(5, (2,)))
    assert world_belief(b) is b
