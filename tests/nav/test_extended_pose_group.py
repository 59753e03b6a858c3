"""The extended-pose SLAM group space :math:`SE_{2+n}(3)` × biases
(:mod:`nav.extended_pose_group`): closed-form Exp/Log against the matrix
exponential, retract/local round trips near 0 and near π, the barycentre of symmetric
clouds, the map to the standard chart against finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from estimators import Euclidean, Product
from nav.extended_pose_group import (
    ExtendedPoseGroup,
    MeanNotConvergedError,
    chain_jacobians,
    jl_apply,
    so3_kit,
)
from nav.quaternion import qexp, qleft_matrix, qmul, qright_matrix, skew
from nav.spaces import UnitQuaternion
from nav.strapdown import dcm_unit as qdcm

N = 2                                  # landmarks: tangent dimension 21, matrices 7 × 7
DIM = 15 + 3 * N
SIDES = ("right", "left")
coord = st.floats(-30.0, 30.0)
unit = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
    lambda v: 0.1 < math.hypot(*v))
# rotation angles: tiny, just below π, anywhere
angle = st.one_of(st.floats(0.0, 1e-6), st.floats(math.pi - 1e-6, math.pi - 1e-12),
                  st.floats(0.0, 3.1))


def _rotvec(axis: list[float], a: float) -> np.ndarray:
    v = np.asarray(axis, dtype=float)
    return a * v / np.linalg.norm(v)


def _tangent(axis, a, rest) -> np.ndarray:
    xi = np.asarray(rest, dtype=float).copy()
    return np.concatenate([xi[:6], _rotvec(axis, a), xi[6:]])


def _state(rng: np.random.Generator) -> np.ndarray:
    return np.concatenate([rng.normal(size=6) * 5, qexp(rng.normal(size=3)),
                           rng.normal(size=6) * 1e-2, rng.normal(size=3 * N) * 10])


def _matrix(x: np.ndarray) -> np.ndarray:
    """The (5 + N) × (5 + N) group matrix [R, v, p, m_i; 0, I]."""
    X = np.eye(5 + N)
    X[:3, :3] = qdcm(x[6:10])
    X[:3, 3], X[:3, 4] = x[3:6], x[0:3]
    for i in range(N):
        X[:3, 5 + i] = x[16 + 3 * i:19 + 3 * i]
    return X


def _algebra(xi: np.ndarray) -> np.ndarray:
    A = np.zeros((5 + N, 5 + N))
    A[:3, :3] = skew(xi[6:9])
    A[:3, 3], A[:3, 4] = xi[3:6], xi[0:3]
    for i in range(N):
        A[:3, 5 + i] = xi[15 + 3 * i:18 + 3 * i]
    return A


def _rot_close(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Rotation vectors equal as rotations (±π about one axis are one rotation)."""
    return bool(np.allclose(qdcm(qexp(a)), qdcm(qexp(b)), atol=tol))


@settings(max_examples=60, deadline=None)
@given(unit, angle, st.lists(coord, min_size=DIM - 3, max_size=DIM - 3))
def test_exp_is_the_matrix_exponential_and_log_inverts_it(axis, a, rest):
    G = ExtendedPoseGroup(N)
    xi = _tangent(axis, a, rest)
    x = G.exp(xi)
    tol = 1e-9 * (1 + np.abs(xi).max())
    assert np.allclose(_matrix(x), scipy.linalg.expm(_algebra(xi)), atol=tol)
    assert np.allclose(x[10:16], xi[9:15])                    # biases: additive
    back = G.log(x)
    assert _rot_close(back[6:9], xi[6:9], 1e-12)
    if a < math.pi - 1e-9:                                    # the log is unique below π
        assert np.allclose(back, xi, rtol=0, atol=tol)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(SIDES), st.integers(0, 2**31), unit, angle,
       st.lists(st.floats(-5.0, 5.0), min_size=DIM - 3, max_size=DIM - 3))
def test_local_inverts_retract_near_zero_and_near_pi(side, seed, axis, a, rest):
    G = ExtendedPoseGroup(N, side)
    x, d = _state(np.random.default_rng(seed)), _tangent(axis, a, rest)
    y = G.retract(x, d)
    assert abs(np.linalg.norm(y[6:10]) - 1.0) < 1e-14
    got = G.local(x, y)
    tol = 1e-8 * (1 + np.abs(x).max())
    assert _rot_close(got[6:9], d[6:9], 1e-12)
    if a < math.pi - 1e-9:
        assert np.allclose(got, d, rtol=0, atol=tol)
    assert np.allclose(G.retract(x, got), y, rtol=0, atol=tol)     # either way, the same y


def test_retract_and_local_are_vectorised_over_points():
    rng = np.random.default_rng(1)
    G = ExtendedPoseGroup(N)
    x, D = _state(rng), rng.normal(size=(5, DIM))
    Y = G.retract(x, D)
    assert np.allclose(Y, np.array([G.retract(x, d) for d in D]), atol=1e-14)
    assert np.allclose(G.local(x, Y), np.array([G.local(x, y) for y in Y]), atol=1e-12)


def test_left_jacobian_and_its_inverse_near_zero_and_pi():
    rng = np.random.default_rng(2)
    u = rng.normal(size=(4, 3))
    for a in (0.0, 1e-9, 1e-3, 0.0999, 0.1001, 2.0, math.pi - 1e-9, math.pi):
        phi = _rotvec([1.0, 2.0, -0.5], a)
        Ju = jl_apply(phi, u)
        assert np.allclose(jl_apply(phi, Ju, inverse=True), u, rtol=0, atol=1e-13)
        # J_l(φ) u is the translation of exp([φ]x, u) (the 4 × 4 matrix exponential)
        A = np.zeros((4, 4))
        A[:3, :3] = skew(phi)
        for k in range(4):
            A[:3, 3] = u[k]
            assert np.allclose(scipy.linalg.expm(A)[:3, 3], Ju[k], rtol=0, atol=1e-13)


def test_so3_kit_is_the_exponential_its_left_jacobian_and_the_quaternion():
    """Exp, J_l, J_l⁻¹ and the quaternion of :func:`so3_kit` (series below 0.1 rad, closed
    forms above) against scipy's matrix exponential and :func:`qexp`, for a batch that
    takes the series only, a mixed batch up to π, and one vector at a time."""
    axis = np.array([1.0, 2.0, -0.5]) / math.sqrt(5.25)
    angles = np.array([0.0, 1e-9, 1e-3, 0.0999, 0.1001, 2.0, math.pi - 1e-9, math.pi])
    kinds = ("exp", "jl", "jl_inv")
    for batch in (angles[:4], angles):
        phi = batch[:, None] * axis
        M, s = so3_kit(phi, kinds, ("qw", "qk"))
        assert np.allclose(np.c_[s[:, :1], s[:, 1:] * phi], qexp(phi), rtol=0, atol=1e-15)
        for i, p in enumerate(phi):
            A = np.zeros((6, 6))                       # expm [[φx, I], [0, 0]] = [[R, J_l], ...]
            A[:3, :3], A[:3, 3:] = skew(p), np.eye(3)
            E = scipy.linalg.expm(A)
            assert np.allclose(M[i, 0], E[:3, :3], rtol=0, atol=1e-14)
            assert np.allclose(M[i, 1], E[:3, 3:], rtol=0, atol=1e-14)
            assert np.allclose(M[i, 2] @ M[i, 1], np.eye(3), rtol=0, atol=1e-13)
            assert np.allclose(so3_kit(p, kinds)[0], M[i], rtol=0, atol=1e-15)


@pytest.mark.parametrize("side", SIDES)
def test_mean_of_a_symmetric_cloud_is_its_centre(side):
    """Points x̄ ⊞ ±δⱼ (a cubature-like cloud, attitude spread ~0.5 rad) have the
    barycentre x̄ exactly; with an unscented-like negative centre weight too."""
    rng = np.random.default_rng(3)
    G = ExtendedPoseGroup(N, side)
    centre = _state(rng)
    D = rng.normal(size=(8, DIM)) * 0.3
    pts = G.retract(centre, np.vstack([np.zeros(DIM), D, -D]))
    for w in (np.r_[0.0, np.full(16, 1 / 16)], np.r_[-0.25, np.full(16, 1.25 / 16)]):
        m = G.mean(pts, w)
        assert np.abs(G.local(centre, m)).max() < 1e-12
        assert np.abs(w @ G.local(m, pts)).max() < 1e-12


@pytest.mark.parametrize("side", SIDES)
def test_mean_is_the_barycentre_of_a_skewed_cloud(side):
    rng = np.random.default_rng(4)
    G = ExtendedPoseGroup(N, side)
    pts = G.retract(_state(rng), rng.normal(size=(12, DIM)) * 0.4)
    w = rng.uniform(0.5, 1.5, size=12)
    w /= w.sum()
    m = G.mean(pts, w)
    assert np.abs(w @ G.local(m, pts)).max() < 1e-12


def test_local_right_after_mean_is_what_a_fresh_computation_gives():
    """``local(mean(points), points)`` takes the cloud's attitude errors from the mean
    (a memo keyed by the quaternions' values): bitwise the same as computing them anew,
    and a cloud changed in place is not served from it."""
    rng = np.random.default_rng(7)
    G = ExtendedPoseGroup(N)
    pts = G.retract(_state(rng), rng.normal(size=(10, DIM)) * 0.2)
    w = np.full(10, 0.1)
    m = G.mean(pts, w)
    reused = G.local(m, pts)
    G.mean(pts[::-1], w)                                       # another cloud: a fresh local
    assert np.array_equal(G.local(m, pts), reused)
    G.mean(pts, w)
    pts[3, 6:10] = qmul(qexp([0.0, 0.0, 0.01]), pts[3, 6:10])  # changed after the mean
    fresh = G.local(m, pts)
    assert abs(fresh[3, 8] - reused[3, 8]) > 1e-3
    G.mean(pts[::-1], w)
    assert np.array_equal(G.local(m, pts), fresh)


def test_transport_columns_are_the_transport_less_the_identity():
    """T = M(y) M(x)⁻¹ moves the rotation columns alone: ``transport_columns`` is T - I on
    the first ``transport_lead`` columns, and T is the identity past them."""
    rng = np.random.default_rng(9)
    G = ExtendedPoseGroup(N)
    x, y = _state(rng), _state(rng)
    E = G.to_world(y, G.from_world(x, np.eye(DIM))) - np.eye(DIM)
    assert not np.any(E[:, :6]) and not np.any(E[:, G.transport_lead:])
    assert np.allclose(G.transport_columns(x, y), E[:, :G.transport_lead], rtol=0, atol=1e-12)


def test_quaternion_product_matrices():
    rng = np.random.default_rng(8)
    a, B = qexp(rng.normal(size=3)), qexp(rng.normal(size=(5, 3)))
    assert np.allclose(B @ qleft_matrix(a).T, qmul(a, B), rtol=0, atol=1e-15)
    assert np.allclose(B @ qright_matrix(a).T, qmul(B, a), rtol=0, atol=1e-15)


def test_mean_that_does_not_converge_raises():
    rng = np.random.default_rng(5)
    G = ExtendedPoseGroup(0, max_iter=1)
    pts = G.retract(_state(rng)[:16], rng.normal(size=(6, 15)))
    with pytest.raises(MeanNotConvergedError, match="did not converge"):
        G.mean(pts, np.full(6, 1 / 6))
    assert issubclass(MeanNotConvergedError, ArithmeticError)


def _standard_chart() -> Product:
    return Product([Euclidean(6), UnitQuaternion(), Euclidean(6 + 3 * N)])


def _world_jacobian(G: ExtendedPoseGroup, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Central difference of the standard error of ``x ⊞ ξ`` in ξ."""
    S, steps = _standard_chart(), eps * np.eye(G.dim)
    return (S.local(x, G.retract(x, steps)) - S.local(x, G.retract(x, -steps))).T / (2 * eps)


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(SIDES), st.integers(0, 2**31), unit, angle)
def test_world_map_matches_finite_differences(side, seed, axis, a):
    rng = np.random.default_rng(seed)
    G = ExtendedPoseGroup(N, side)
    x = _state(rng)
    x[6:10] = qexp(_rotvec(axis, a))
    M = _world_jacobian(G, x)
    A = rng.normal(size=(DIM, 5))
    assert np.allclose(G.to_world(x, A), M @ A, atol=1e-6)
    assert np.allclose(G.from_world(x, G.to_world(x, A)), A, atol=1e-11)
    assert np.allclose(G.right_world(x, A.T), A.T @ M, atol=1e-6)
    assert np.allclose(G.to_world(x, A[:, 0]), M @ A[:, 0], atol=1e-6)   # one column


def test_chain_jacobians_are_the_chain_rule():
    rng = np.random.default_rng(6)
    G = ExtendedPoseGroup(N)
    x, y = _state(rng), _state(rng)
    F, Gw = rng.normal(size=(DIM, DIM)), rng.normal(size=(DIM, 3))
    Fx, Gx = chain_jacobians(G, G, x, y, F, Gw)
    My, Mx = _world_jacobian(G, y), _world_jacobian(G, x)
    assert np.allclose(My @ Fx, F @ Mx, atol=1e-5)
    assert np.allclose(My @ Gx, Gw, atol=1e-5)


def test_sizes_and_bad_side():
    G = ExtendedPoseGroup(3)
    assert (G.ambient_dim, G.dim) == (25, 24)
    with pytest.raises(ValueError, match="side"):
        ExtendedPoseGroup(1, "middle")  # type: ignore[arg-type]
