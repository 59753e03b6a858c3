"""The planar SLAM group space :math:`SE_{1+n}(2)` (:mod:`estimators.slam_group`): closed-form
Exp/Log against the matrix exponential, retract/local round trips near 0 and near π, the
world-frame Jacobian against finite differences, the barycentre.

A linear-Gaussian reduction test does not apply here: a group space is not a vector space
(its retraction rotates every landmark with the heading), so no model is linear in it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from estimators import Wrapped
from estimators.slam_group import (
    SlamGroup,
    exp_map,
    invariant_h,
    invariant_jacobians,
    log_map,
    so2_v,
    so2_v_inv,
)
from estimators.spaces import MeanNotConvergedError

N = 2                     # landmarks in the test states: dimension 7
DIM = 3 + 2 * N
coord = st.floats(-50.0, 50.0)
small_angle = st.floats(-1e-5, 1e-5)
near_pi = st.floats(math.pi - 1e-6, math.pi - 1e-12)
angle = st.one_of(small_angle, near_pi, near_pi.map(lambda a: -a), st.floats(-3.1, 3.1))
SIDES = ("right", "left")


def _vec(heading: float, rest: list[float]) -> np.ndarray:
    v = np.array(rest, dtype=float)
    return np.concatenate([v[:2], [heading], v[2:]])


def _algebra(xi: np.ndarray) -> np.ndarray:
    """The (3 + N) × (3 + N) matrix of se_{1+N}(2) for ξ = [u_p, θ, u_l...]."""
    A = np.zeros((3 + N, 3 + N))
    A[0, 1], A[1, 0] = -xi[2], xi[2]
    cols = [xi[0:2]] + [xi[3 + 2 * i:5 + 2 * i] for i in range(N)]
    for j, c in enumerate(cols):
        A[:2, 2 + j] = c
    return A


def _matrix(x: np.ndarray) -> np.ndarray:
    """The group element's matrix."""
    X = np.eye(3 + N)
    c, s = math.cos(x[2]), math.sin(x[2])
    X[:2, :2] = [[c, -s], [s, c]]
    X[:2, 2] = x[:2]
    for i in range(N):
        X[:2, 3 + i] = x[3 + 2 * i:5 + 2 * i]
    return X


@settings(max_examples=60, deadline=None)
@given(angle, st.lists(coord, min_size=DIM - 1, max_size=DIM - 1))
def test_exp_is_the_matrix_exponential_and_log_inverts_it(th, rest):
    xi = _vec(th, rest)
    x = exp_map(xi)
    assert np.allclose(_matrix(x), scipy.linalg.expm(_algebra(xi)), atol=1e-9 * (1 + abs(xi).max()))
    back = log_map(x)
    if abs(abs(th) - math.pi) < 1e-9:            # ±π are one rotation: compare modulo 2π
        back[2] = th
    assert np.allclose(back, xi, rtol=0, atol=1e-9 * (1 + abs(xi).max()))


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(SIDES), st.floats(-3.1, 3.1), st.lists(coord, min_size=DIM - 1,
       max_size=DIM - 1), angle, st.lists(st.floats(-5.0, 5.0), min_size=DIM - 1,
       max_size=DIM - 1))
def test_local_inverts_retract_near_zero_and_near_pi(side, phi, rest, th, drest):
    G = SlamGroup(N, side)
    x, d = _vec(phi, rest), _vec(th, drest)
    got = G.local(x, G.retract(x, d))
    if abs(abs(th) - math.pi) < 1e-9:
        got[2] = th
    assert np.allclose(got, d, rtol=0, atol=1e-8 * (1 + abs(x).max()))


def test_v_and_its_inverse_near_zero_and_pi():
    t = np.array([0.0, 1e-9, -1e-5, 1e-3])
    series = 1.0 - t**2 / 6.0 + 1j * (t / 2.0 - t**3 / 24.0)
    assert np.allclose(so2_v(t), series, rtol=0, atol=1e-12)
    assert np.allclose(so2_v_inv(t), 1.0 - t**2 / 12.0 - 0.5j * t, rtol=0, atol=1e-12)
    th = np.linspace(-math.pi, math.pi - 1e-9, 101)
    assert np.allclose(so2_v(th) * so2_v_inv(th), 1.0, atol=1e-13)


def _world_jacobian(G: SlamGroup, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Central difference of the standard error of ``x ⊞ ξ`` in ξ."""
    W = Wrapped(G.dim, (2,))
    steps = eps * np.eye(G.dim)
    return (W.local(x, G.retract(x, steps)) - W.local(x, G.retract(x, -steps))).T / (2 * eps)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(SIDES), angle, st.lists(coord, min_size=DIM - 1, max_size=DIM - 1))
def test_world_jacobian_matches_finite_differences(side, phi, rest):
    G = SlamGroup(N, side)
    x = _vec(phi, rest)
    M = _world_jacobian(G, x)
    A = np.random.default_rng(0).normal(size=(DIM, 4))
    assert np.allclose(G.to_world(x, A), M @ A, atol=1e-6)
    assert np.allclose(G.from_world(x, G.to_world(x, A)), A, atol=1e-12 * (1 + abs(x).max()))
    assert np.allclose(G.right_world(x, A.T), A.T @ M, atol=1e-6)
    assert np.allclose(invariant_h(G, x, A.T), A.T @ M, atol=1e-6)


def test_invariant_jacobians_are_the_chain_rule():
    """F_ξ = M(y)⁻¹ F M(x) for an arbitrary F, and the identity for a pure right
    multiplication (group-affine motion) under right-invariant error."""
    rng = np.random.default_rng(1)
    G = SlamGroup(N, "right")
    x, y = rng.normal(size=DIM) * 10, rng.normal(size=DIM) * 10
    F, Gw = rng.normal(size=(DIM, DIM)), rng.normal(size=(DIM, 3))
    Fx, Gx = invariant_jacobians(G, G, x, y, F, Gw)
    My, Mx = _world_jacobian(G, y), _world_jacobian(G, x)
    assert np.allclose(My @ Fx, F @ Mx, atol=1e-5)
    assert np.allclose(My @ Gx, Gw, atol=1e-5)


@pytest.mark.parametrize("side", SIDES)
def test_mean_is_the_barycentre_with_negative_weights(side):
    """Σ wᵢ (xᵢ ⊟ x̄) = 0 at the returned mean (unscented-like weights, one negative)."""
    rng = np.random.default_rng(2)
    G = SlamGroup(N, side)
    centre = rng.normal(size=DIM) * 20
    centre[2] = 3.0                                  # the cloud straddles ±π
    pts = G.retract(centre, rng.normal(size=(15, DIM)) * 0.2)
    w = np.full(15, 1.2 / 14)
    w[0] = -0.2
    m = G.mean(pts, w)
    assert np.abs(w @ G.local(m, pts)).max() < 1e-11
    assert np.abs(G.local(centre, m)).max() < 0.5


def test_bad_side_is_refused():
    with pytest.raises(ValueError, match="side"):
        SlamGroup(1, "middle")  # type: ignore[arg-type]


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize("n", [0, 1, 6])
def test_transport_is_t_p_tt_and_keeps_the_factor_lower_triangular(side, n):
    """:math:`T = M(x_{new}) M(x_{old})^{-1}` from explicit matrices; the factor form stays
    lower triangular with a non-negative diagonal and agrees with the dense form."""
    rng = np.random.default_rng(n)
    g = SlamGroup(n, side)
    x0 = rng.normal(size=g.dim) * 5.0
    x1 = x0 + rng.normal(size=g.dim)
    A = rng.normal(size=(g.dim, g.dim))
    P = A @ A.T
    M = [g.to_world(x, np.eye(g.dim)) for x in (x0, x1)]
    T = M[1] @ np.linalg.inv(M[0])
    expect = T @ P @ T.T
    dense = g.transport(x0, x1, cov=P)
    S = g.transport(x0, x1, sqrt=np.linalg.cholesky(P))
    scale = np.abs(expect).max()
    assert np.abs(dense - expect).max() < 1e-12 * scale
    assert np.abs(S @ S.T - expect).max() < 1e-12 * scale
    assert not np.triu(S, 1).any() and (np.diagonal(S) >= 0.0).all()
    assert np.abs(T - np.eye(g.dim)).max() > 0.1       # not the identity


@pytest.mark.parametrize("side", SIDES)
def test_retract_world_is_the_group_step_of_a_world_correction(side):
    """A world-chart step δ is the group step :math:`M(x)^{-1}δ`: equal to first order,
    second-order different, and exact at zero."""
    rng = np.random.default_rng(5)
    g = SlamGroup(N, side)
    x = rng.normal(size=DIM) * 5.0
    d = rng.normal(size=DIM)
    assert np.array_equal(g.retract_world(x, np.zeros(DIM)), x)
    for h, tol in ((1e-4, 1e-7), (1e-6, 1e-11)):
        y = g.retract_world(x, h * d)
        assert np.abs(Wrapped(DIM, (2,)).local(x, y) - h * d).max() < tol * 50


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@pytest.mark.parametrize("side", SIDES)
def test_every_operation_takes_a_batch_axis_member_by_member(side):
    """A batch (B, ...) through every operation the filters and the batched campaign call
    gives each member's one-belief result (to 1e-12), headings near ±π included; a mean
    that fails for one member of a batch raises as that member alone does."""
    rng = np.random.default_rng(11)
    g, B, m = SlamGroup(3, side), 4, 13
    d = g.dim
    x = rng.normal(size=(B, d)) * 20.0
    x[:, 2] = [3.1, -3.1, 0.3, -1e-9]
    xi = rng.normal(size=(B, m, d)) * 0.3
    A = rng.normal(size=(B, d, 5))
    H = rng.normal(size=(B, 6, d))
    F = rng.normal(size=(B, d, d))
    w = np.full(m, 1.3 / (m - 1))
    w[0] = -0.3
    S = np.tril(rng.normal(size=(B, d, d)))
    pts = g.retract(x[:, None, :], xi)
    batched = {"retract": pts, "retract-1": g.retract(x, xi[:, 0]),
               "local": g.local(x[:, None, :], pts), "mean": g.mean(pts, w),
               "to_world": g.to_world(x, A), "from_world": g.from_world(x, A),
               "right_world": g.right_world(x, H), "retract_world": g.retract_world(x, A[..., 0]),
               "lower_factor": g.lower_factor(S.copy()),
               "invariant_h": invariant_h(g, x, H),
               "jacobians": np.concatenate(invariant_jacobians(g, g, x, pts[:, 1], F, A), -1)}
    for j in range(B):
        one = {"retract": g.retract(x[j], xi[j]), "retract-1": g.retract(x[j], xi[j, 0]),
               "local": g.local(x[j], pts[j]), "mean": g.mean(pts[j], w),
               "to_world": g.to_world(x[j], A[j]), "from_world": g.from_world(x[j], A[j]),
               "right_world": g.right_world(x[j], H[j]),
               "retract_world": g.retract_world(x[j], A[j, :, 0]),
               "lower_factor": g.lower_factor(S[j].copy()),
               "invariant_h": invariant_h(g, x[j], H[j]),
               "jacobians": np.concatenate(invariant_jacobians(g, g, x[j], pts[j, 1], F[j],
                                                               A[j]), -1)}
        for key, value in one.items():
            assert batched[key][j].shape == value.shape, key
            assert _rel(batched[key][j], value) <= 1e-12, key
    assert not np.triu(batched["lower_factor"][:, [0, 3, 5, 7]][:, :, [1, 4, 6, 8]]).any()
    # Σ wᵢ V⁻¹(Δᵢ) = 0 for member 1: headings Δ = 0, ±2.5 and w₁ = w₂ = 1 / (2 (1 - c)),
    # c = Re V⁻¹(2.5) = 1.25 cot 1.25 (the first weight negative)
    c = 1.25 / math.tan(1.25)
    w3 = np.array([1.0 - 1.0 / (1.0 - c), 0.5 / (1.0 - c), 0.5 / (1.0 - c)])
    cloud = g.retract(x[:, None, :], rng.normal(size=(B, 3, d)) * 0.1)
    cloud[1, :, 2] = 0.3 + np.array([0.0, 2.5, -2.5])
    with pytest.raises(MeanNotConvergedError) as alone:
        g.mean(cloud[1], w3)
    with pytest.raises(MeanNotConvergedError) as in_batch:
        g.mean(cloud, w3)
    assert str(in_batch.value) == str(alone.value)
    g.mean(cloud[[0, 2, 3]], w3)  # the others have a mean
