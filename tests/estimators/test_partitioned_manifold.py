"""Partitioned (local) steps with ambient != tangent: a quaternion vehicle and 3-D landmarks.

Vehicle ``[p (3), q (4), b (3)]`` (ambient 10, tangent 9) on
``Product([Euclidean(3), UnitQuaternion(), Euclidean(3 + 3N)])``, landmarks in 3-D.  The
models are nonlinear in the vehicle and linear in the map:

* motion ``q' = q ⊗ Exp(ω dt) ⊗ Exp(w_ω dt)``, ``p' = p + C(q)(a - b + w_a) dt``, ``b' = b``,
  the map copied (noise as an input, or additive in the tangent);
* measurement ``z_j = C(q)ᵀ (m_j - p)`` per observed landmark;
* augmentation ``m = p + C(q)(z + w)``.

What holds (``estimators.partitioned``, "Agreement with joint mode"):

* every local step is the filter's own step on the block's marginal, carried to the rest of
  the state by the regression ``A = P_x,a P_aa⁻¹`` - for every filter, to 1e-9;
* EKF: local = joint (its Jacobians see only the block);
* SRCDKF: local = joint in all three steps here (prediction and augmentation on any model;
  the update because the measurement is linear in the landmarks);
* SRCKF/SRUKF: local = joint only when the block is the whole state; otherwise joint mode
  spreads the block's points by sqrt(n), not sqrt(n_block) - a different quadrature.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    BlockLayout,
    Euclidean,
    Measurement,
    Noise,
    Product,
    SqrtGaussian,
    Transition,
    make_filter,
)
from estimators.linearise import numerical_jacobian
from nav.quaternion import qconj, qexp, qmul, qnormalize, qrotate, qto_dcm, skew
from nav.spaces import UnitQuaternion

QUAT = UnitQuaternion()
DT = 0.1
U = (np.array([0.3, -0.2, 0.5]), np.array([2.0, 0.5, -0.3]))   # (ω, a)
R = np.diag([0.05, 0.04, 0.06]) ** 2
FILTERS = ("ekf", "srckf", "srukf", "srcdkf")
NEG_UKF = {"beta": 0.0, "kappa": -1.0}
CASES = [(n, {}) for n in FILTERS] + [("srukf", NEG_UKF)]


def space(k: int) -> Product:
    return Product([Euclidean(3), QUAT, Euclidean(3 + 3 * k)])


LAYOUT = BlockLayout(10, 9, 3, 3, space)


# --------------------------------------------------------------------------- models

def motion(n_lm: int, additive: bool, jacobians: bool = True) -> Transition:
    """Moves the vehicle of a state with ``n_lm`` landmarks; the map is copied."""
    d = 9 + 3 * n_lm
    phi = U[0] * DT
    Rphi = qto_dcm(qexp(phi))

    def f(X, u, W=None):
        W = np.zeros((X.shape[0], 6)) if W is None else W
        q = X[:, 3:7]
        Y = X.copy()
        Y[:, :3] = X[:, :3] + qrotate(q, u[1] - X[:, 7:10] + W[:, 3:]) * DT
        Y[:, 3:7] = qnormalize(qmul(qmul(q, qexp(phi)), qexp(W[:, :3] * DT)))
        return Y

    def jac(x, u):
        C = qto_dcm(x[3:7])
        F = np.eye(d)
        F[:3, 3:6] = -C @ skew(u[1] - x[7:10]) * DT
        F[:3, 6:9] = -C * DT
        F[3:6, 3:6] = Rphi.T
        G = np.zeros((d, 6))
        G[3:6, :3] = np.eye(3) * DT
        G[:3, 3:] = C * DT
        return F if additive else (F, G)

    j = jac if jacobians else None
    if additive:
        Qv = np.diag(np.r_[np.full(3, 1e-3), np.full(3, 4e-4), np.full(3, 1e-6)])
        cov, sqrt = np.zeros((d, d)), np.zeros((d, d))
        cov[:9, :9], sqrt[:9, :9] = Qv, np.sqrt(Qv)
        return Transition(lambda X, u: f(X, u), Noise(cov, sqrt), additive=True, jacobian=j)
    return Transition(f, Noise.from_sigmas([0.02] * 3 + [0.1] * 3), additive=False, jacobian=j)


def observe(slots, jacobians: bool = True) -> Measurement:
    """``z_j = C(q)ᵀ (m_j - p)`` for the landmarks in ``slots``."""
    slots = np.asarray(slots, dtype=int)
    cols = 10 + 3 * slots[:, None] + np.arange(3)

    def h(X):
        d = qrotate(qconj(X[:, None, 3:7]), X[:, cols] - X[:, None, :3])
        return d.reshape(X.shape[0], -1)

    def jac(x):
        C = qto_dcm(x[3:7])
        H = np.zeros((3 * len(slots), (x.shape[0] - 1)))
        for i, s in enumerate(slots):
            d = C.T @ (x[cols[i]] - x[:3])
            H[3 * i:3 * i + 3, :3] = -C.T
            H[3 * i:3 * i + 3, 3:6] = skew(d)
            H[3 * i:3 * i + 3, 9 + 3 * s:12 + 3 * s] = C.T
        return H

    k = len(slots)
    return Measurement(h, Noise.from_cov(np.kron(np.eye(k), R)),
                       jacobian=jac if jacobians else None)


def augment(n_lm: int, z, jacobians: bool = True) -> Transition:
    """``s' = [s; p + C(q)(z_i + w_i)]`` for the new landmarks in ``z``."""
    k = len(z) // 3
    n = 9 + 3 * n_lm

    def f(X, u, W):
        Z = (u[None] + W).reshape(X.shape[0], k, 3)
        new = X[:, None, :3] + qrotate(X[:, None, 3:7], Z)
        return np.hstack([X, new.reshape(X.shape[0], -1)])

    def jac(x, u):
        C = qto_dcm(x[3:7])
        F = np.zeros((n + 3 * k, n))
        F[:n] = np.eye(n)
        G = np.zeros((n + 3 * k, 3 * k))
        for i in range(k):
            F[n + 3 * i:n + 3 * i + 3, :3] = np.eye(3)
            F[n + 3 * i:n + 3 * i + 3, 3:6] = -C @ skew(u[3 * i:3 * i + 3])
            G[n + 3 * i:n + 3 * i + 3, 3 * i:3 * i + 3] = C
        return F, G

    return Transition(f, Noise.from_cov(np.kron(np.eye(k), R)), additive=False,
                      space=space(n_lm + k), jacobian=jac if jacobians else None)


def belief(filt, n_lm: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    q = qexp(rng.normal(size=3))
    mean = np.concatenate([rng.normal(size=3), q, 0.05 * rng.normal(size=3),
                           rng.uniform(-8.0, 8.0, 3 * n_lm)])
    n = 9 + 3 * n_lm
    scale = np.r_[np.full(3, 0.3), np.full(3, 0.08), np.full(3, 0.02), np.full(3 * n_lm, 0.4)]
    A = rng.normal(size=(n, n)) * scale[:, None]
    return filt.init(mean, space(n_lm), cov=A @ A.T + 1e-3 * np.diag(scale))


def close(a, b, tol: float = 1e-9) -> None:
    np.testing.assert_allclose(a.mean, b.mean, atol=tol)
    np.testing.assert_allclose(a.cov, b.cov, atol=tol)


# --------------------------------------------------------------------------- checks

def test_layout_sizes_from_the_spaces():
    assert BlockLayout.of(space) == LAYOUT
    assert LAYOUT.rows([2, 0]).tolist() == list(range(9)) + [15, 16, 17, 9, 10, 11]
    assert LAYOUT.cols([2, 0]).tolist() == list(range(10)) + [16, 17, 18, 10, 11, 12]
    assert LAYOUT.n_landmarks(9 + 3 * 4) == 4
    with pytest.raises(ValueError, match="do not match"):
        BlockLayout(10, 10, 3, 3, space)


@pytest.mark.parametrize("additive", [False, True])
def test_analytic_jacobians_match_numerical(additive):
    x = belief(make_filter("ekf"), 2).mean
    tr = motion(2, additive)
    J, _ = numerical_jacobian(lambda X, W: tr.f(X, U) if additive else tr.f(X, U, W), x,
                              space(2), space(2), 0 if additive else 6)
    FG = tr.jacobian(x, U)
    np.testing.assert_allclose(np.hstack([FG] if additive else FG), J, atol=1e-7)
    me = observe([1, 0])
    Hn, _ = numerical_jacobian(lambda X, W: me.h(X), x, space(2), me.space)
    np.testing.assert_allclose(me.jacobian(x), Hn, atol=1e-7)
    z = np.array([3.0, 1.0, -2.0])
    au = augment(2, z)
    J, _ = numerical_jacobian(lambda X, W: au.f(X, z, W), x, space(2), space(3), 3)
    np.testing.assert_allclose(np.hstack(au.jacobian(x, z)), J, atol=1e-7)


def _reference_predict(filt, b, model, u):
    """The filter's own prediction of ``[f(v); v]`` on the vehicle marginal, carried to
    the map by ``A = P_v'v P_vv⁻¹``."""
    x, P = b.mean, b.cov
    vs = space(0)
    copy = Product([vs, vs])
    if model.additive:
        def f(X, u):
            return np.hstack([model.f(X, u), X])
        noise = Noise(np.kron(np.diag([1.0, 0.0]), model.noise.cov),
                      np.kron(np.diag([1.0, 0.0]), model.noise.sqrt))
        tr = Transition(f, noise, additive=True, space=copy)
    else:
        tr = Transition(lambda X, u, W: np.hstack([model.f(X, u, W), X]), model.noise,
                        additive=False, space=copy)
    out = filt.predict(filt.init(x[:10], vs, cov=P[:9, :9]), tr, u)
    Pc = out.cov
    A = Pc[:9, 9:] @ np.linalg.inv(P[:9, :9])
    Pn = P.copy()
    Pn[:9, :9] = Pc[:9, :9]
    Pn[:9, 9:] = A @ P[:9, 9:]
    Pn[9:, :9] = Pn[:9, 9:].T
    return np.concatenate([out.mean[:10], x[10:]]), Pn


def _reference_update(filt, b, slots, z):
    """The filter's own update of the block marginal; the rest follows by
    ``A = P_x,s P_ss⁻¹``: ``x⁺ = x ⊞ A δs``, ``P⁺ = P - A (P_ss - P_ss⁺) Aᵀ``."""
    x, P = b.mean, b.cov
    rows, cols = LAYOUT.rows(slots), LAYOUT.cols(slots)
    bs_space = space(len(slots))
    Pss = P[np.ix_(rows, rows)]
    post, inn = filt.update(filt.init(x[cols], bs_space, cov=Pss),
                            observe(np.arange(len(slots)), jacobians=False), z)
    A = P[:, rows] @ np.linalg.inv(Pss)
    ds = bs_space.local(x[cols], post.mean)
    return b.space.retract(x, A @ ds), P - A @ (Pss - post.cov) @ A.T, inn.nis


def _reference_augment(filt, b, z):
    x, P = b.mean, b.cov
    out = filt.predict(filt.init(x[:10], space(0), cov=P[:9, :9]),
                       augment(0, z, jacobians=False), z)
    Pc = out.cov
    A = Pc[9:, :9] @ np.linalg.inv(P[:9, :9])
    n, m = len(P), len(z)
    Pn = np.zeros((n + m, n + m))
    Pn[:n, :n] = P
    Pn[n:, :n] = A @ P[:9]
    Pn[:n, n:] = Pn[n:, :n].T
    Pn[n:, n:] = Pc[9:, 9:]
    return np.concatenate([x, out.mean[10:]]), Pn


@pytest.mark.parametrize("additive", [False, True])
@pytest.mark.parametrize("name, params", CASES)
def test_local_step_is_the_filters_own_step_on_the_block(name, params, additive):
    """Any model: the block's marginal through the filter itself, then the regression."""
    filt = make_filter(name, **params)
    steps = filt.partitioned(LAYOUT)
    b = belief(filt, 4)
    mo = motion(0, additive, jacobians=False)
    got = steps.predict(b, mo, U)
    mean, P = _reference_predict(filt, b, mo, U)
    np.testing.assert_allclose(got.mean, mean, atol=1e-9)
    np.testing.assert_allclose(got.cov, P, atol=1e-9)
    z = np.array([1.0, -2.0, 0.5, 4.0, 1.0, -1.0])
    got, inn = steps.update(b, np.array([3, 1]), observe(np.arange(2), jacobians=False), z)
    mean, P, nis = _reference_update(filt, b, np.array([3, 1]), z)
    np.testing.assert_allclose(got.mean, mean, atol=1e-9)
    np.testing.assert_allclose(got.cov, P, atol=1e-9)
    assert inn.nis == pytest.approx(nis, rel=1e-9)
    z = np.array([3.0, 1.0, -2.0, 0.5, 4.0, 2.0])
    got = steps.augment(b, augment(0, z, jacobians=False), z)
    mean, P = _reference_augment(filt, b, z)
    assert got.dim == b.dim + 6 and got.mean.shape == (10 + 3 * 6,)
    np.testing.assert_allclose(got.mean, mean, atol=1e-9)
    np.testing.assert_allclose(got.cov, P, atol=1e-9)


def _run_ops(filt, local: bool, additive: bool):
    """predict, augment 2, predict x2, augment 1, update [1], predict x5, update [2, 0]
    (local mode defers each prediction's map update, folds after four predictions)."""
    steps = filt.partitioned(LAYOUT)
    b = belief(filt, 0, seed=5)
    nis = []

    def predict(b):
        if local:
            return steps.predict(b, motion(0, additive), U)
        return filt.predict(b, motion(LAYOUT.n_landmarks(b.dim), additive), U)

    def add(b, z):
        if local:
            return steps.augment(b, augment(0, z), z)
        return filt.predict(b, augment(LAYOUT.n_landmarks(b.dim), z), z)

    def update(b, slots, z):
        if local:
            b, inn = steps.update(b, np.array(slots), observe(np.arange(len(slots))), z)
        else:
            b, inn = filt.update(b, observe(slots), z)
        nis.append(inn.nis)
        return b

    b = predict(b)
    b = add(b, np.array([3.0, 1.0, -2.0, -4.0, 2.0, 1.0]))
    b = predict(predict(b))
    b = add(b, np.array([5.0, 5.0, 0.5]))
    b = update(b, [1], np.array([-3.5, 2.5, 1.5]))
    for _ in range(5):
        b = predict(b)
    b = update(b, [2, 0], np.array([3.2, 6.9, -1.1, 2.1, 0.4, -2.0]))
    return b, np.array(nis)


@pytest.mark.parametrize("additive", [False, True])
@pytest.mark.parametrize("name", ["ekf", "srcdkf"])
def test_ekf_and_cdkf_local_equal_joint(name, additive):
    """EKF: any model.  SRCDKF: h does not depend on the dimension and the measurement is
    linear in the landmarks, so joint mode's points along landmark columns are exact."""
    filt = make_filter(name)
    bj, nis_j = _run_ops(filt, False, additive)
    bl, nis_l = _run_ops(filt, True, additive)
    assert bl.dim == bj.dim == 18 and bl.mean.shape == (19,)
    close(bl, bj)
    np.testing.assert_allclose(nis_l, nis_j, rtol=1e-9)


@pytest.mark.parametrize("name, params", CASES)
def test_local_equals_joint_when_the_block_is_the_whole_state(name, params):
    filt = make_filter(name, **params)
    steps = filt.partitioned(LAYOUT)
    b0 = belief(filt, 0)
    for additive in (False, True):
        close(steps.predict(b0, motion(0, additive), U), filt.predict(b0, motion(0, additive), U))
    z = np.array([3.0, 1.0, -2.0])
    close(steps.augment(b0, augment(0, z), z), filt.predict(b0, augment(0, z), z))
    b2 = belief(filt, 2, seed=3)
    z = np.array([1.0, -2.0, 0.5, 4.0, 1.0, -1.0])
    lo, inn_l = steps.update(b2, np.arange(2), observe(np.arange(2)), z)
    jo, inn_j = filt.update(b2, observe(np.arange(2)), z)
    close(lo, jo)
    assert inn_l.nis == pytest.approx(inn_j.nis, rel=1e-9)


@pytest.mark.parametrize("name", ["srckf", "srukf"])
def test_cubature_and_unscented_local_differ_from_joint(name):
    """Not equal once landmarks lie outside the block: a different quadrature of the same
    nonlinearity (large here: the test belief has an attitude sigma of about 0.3 rad)."""
    filt = make_filter(name)
    steps = filt.partitioned(LAYOUT)
    b = belief(filt, 4)
    z = np.array([3.0, 1.0, -2.0])
    zz = observe([3, 1]).h(b.mean[None])[0] + 0.05
    pairs = [(steps.predict(b, motion(0, False), U), filt.predict(b, motion(4, False), U)),
             (steps.augment(b, augment(0, z), z), filt.predict(b, augment(4, z), z)),
             (steps.update(b, np.array([3, 1]), observe(np.arange(2)), zz)[0],
              filt.update(b, observe([3, 1]), zz)[0])]
    for lo, jo in pairs:
        assert np.abs(lo.mean - jo.mean).max() > 1e-6


def test_vehicle_marginal_of_a_wide_factor():
    filt = make_filter("srckf")
    b = filt.partitioned(LAYOUT).predict(belief(filt, 3), motion(0, True), U)
    assert b.sqrt.shape[1] > b.dim                       # deferred columns ride along
    v = LAYOUT.vehicle(b)
    assert v.mean.shape == (10,) and v.space == space(0)
    np.testing.assert_allclose(v.cov, b.cov[:9, :9], atol=1e-12)
    g = LAYOUT.vehicle(make_filter("ekf").init(b.mean, b.space, cov=b.cov))
    np.testing.assert_allclose(g.cov, b.cov[:9, :9], atol=0)


def test_quaternion_stays_unit_and_the_factor_lower_triangular():
    filt = make_filter("srckf")
    b, _ = _run_ops(filt, True, True)
    assert abs(np.linalg.norm(b.mean[3:7]) - 1.0) < 1e-12
    assert isinstance(b, SqrtGaussian) and b.sqrt.shape == (18, 18)
    assert np.allclose(np.triu(b.sqrt, 1), 0.0)
