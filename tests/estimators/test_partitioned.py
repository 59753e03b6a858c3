"""Partitioned (``local`` mode) steps, ``filt.partitioned(layout)`` (estimators.partitioned),
on planar models against joint mode and dense references.

* the O(k n²) Cholesky update/downdate sweeps equal a refactorisation;
* on a model linear in the whole state (vehicle and map) local and joint agree to 1e-9
  for every filter (both are the Kalman filter);
* on the nonlinear planar models each local step equals a dense, textbook statistical
  linearisation of the block (P_xz = P_x,s P_ss⁻¹ P_sz, ...), the SRUKF's negative centre
  weight and the SRCDKF's divided differences included; local equals joint exactly when
  the block is the whole state; the EKF agrees with joint mode on the whole run;
* on nonlinear models the SRCDKF's prediction and augmentation equal joint mode (its
  step h does not depend on the dimension); the SRCKF/SRUKF differ from joint mode in
  every step (joint mode spreads the block's points by sqrt(n)): by millimetres here;
* only the filters in PARTITIONED_FILTERS have the steps; the others refuse clearly.

Ambient != tangent (a quaternion vehicle): ``test_partitioned_manifold.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    FILTER_NAMES,
    PARTITIONED_FILTERS,
    ROBUST_FILTER_NAMES,
    BlockLayout,
    Euclidean,
    Measurement,
    Noise,
    NoPartitionedModeError,
    SqrtGaussian,
    Transition,
    Wrapped,
)
from estimators.linalg import NotPositiveDefiniteError, chol_update, chol_update_sweep, tria
from estimators.sigma import draw
from slam.kinds.planar.models import augmentation_model, motion_model, observation_model
from slam.kinds.planar.run import run_once
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import PLANAR_LAYOUT, run_slam
from tests.small_worlds import small_world
from worlds.schema import WorldError

FILTERS = ("ekf", "srckf", "srukf", "srcdkf")
# the SRUKF with a negative centre covariance weight (beta = 0, kappa = -1)
NEG_UKF = {"beta": 0.0, "kappa": -1.0}
CASES = [(n, {}) for n in FILTERS] + [("srukf", NEG_UKF)]


def make(name, params):
    from estimators import make_filter

    return make_filter(name, **params)


def cov(b):
    return b.cov


# --------------------------------------------------------------------------- linalg

@pytest.mark.parametrize("n, k, block", [(1, 1, 64), (5, 3, 2), (70, 3, 16), (150, 4, 64)])
def test_sweep_update_and_downdate_equal_refactorisation(n, k, block):
    rng = np.random.default_rng(n + k)
    L = tria(rng.normal(size=(n, 2 * n)))
    X = rng.normal(size=(n, k))
    up = chol_update_sweep(L, X, 1.0, block)
    np.testing.assert_allclose(up, np.linalg.cholesky(L @ L.T + X @ X.T), atol=1e-12)
    np.testing.assert_allclose(up, chol_update(L, X, 1.0), atol=1e-12)
    np.testing.assert_allclose(chol_update(L, X, 1.0, method="sweep"), up, atol=0)
    Y = rng.normal(size=(n, k))
    D = L @ (Y * 0.95 / np.linalg.norm(Y, 2))
    down = chol_update_sweep(L, D, -1.0, block)
    np.testing.assert_allclose(down, np.linalg.cholesky(L @ L.T - D @ D.T), atol=1e-11)
    np.testing.assert_allclose(down, chol_update(L, D, -1.0), atol=1e-11)
    assert np.allclose(np.triu(down, 1), 0.0) and np.all(np.diagonal(down) > 0)


def test_sweep_update_of_a_singular_factor_and_failing_downdate():
    S = np.zeros((4, 4))
    S[2, 2] = 1.0
    v = np.array([1.0, 2.0, 0.0, 3.0])
    up = chol_update_sweep(S, v, 1.0)
    np.testing.assert_allclose(up @ up.T, S @ S.T + np.outer(v, v), atol=1e-14)
    with pytest.raises(NotPositiveDefiniteError):
        chol_update_sweep(np.eye(3), np.array([0.0, 1.5, 0.0]), -1.0)


# --------------------------------------------------------------------------- the interface

@pytest.mark.parametrize("name", FILTER_NAMES + ROBUST_FILTER_NAMES)
def test_partitioned_steps_are_reached_through_the_filter(name):
    filt = make(name, {})
    assert filt.supports_partitioned == (name in PARTITIONED_FILTERS)
    if filt.supports_partitioned:
        steps = filt.partitioned(PLANAR_LAYOUT)
        assert steps.layout is PLANAR_LAYOUT and steps.filt is filt
        return
    with pytest.raises(NoPartitionedModeError, match="no local mode") as err:
        filt.partitioned(PLANAR_LAYOUT)
    assert isinstance(err.value, ValueError)


def test_block_layout_rows_and_sizes():
    assert BlockLayout.of(_space) == LINEAR
    assert PLANAR_LAYOUT.rows([2, 0]).tolist() == [0, 1, 2, 7, 8, 3, 4]
    assert PLANAR_LAYOUT.cols([2, 0]).tolist() == [0, 1, 2, 7, 8, 3, 4]
    with pytest.raises(ValueError, match="do not match"):
        BlockLayout(3, 3, 3, 3, _space)


def test_local_augmentation_needs_the_noise_as_an_input():
    mo = Transition(lambda X, u: X, Noise.from_cov(np.eye(3)))
    for name in PARTITIONED_FILTERS:
        filt = make(name, {})
        b = filt.init(np.zeros(3), _space(0), cov=np.eye(3))
        with pytest.raises(ValueError, match="non-additive"):
            filt.partitioned(LINEAR).augment(b, mo, None)


# --------------------------------------------------------------------------- linear model

def _space(k: int) -> Wrapped:
    return Wrapped(3 + 2 * k, (2,))


LINEAR = BlockLayout(3, 3, 2, 2, _space)
B = np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.1], [0.05, 0.0, 1.0]])
F = np.array([[1.0, 0.0, 0.3], [0.0, 1.0, -0.2], [0.0, 0.0, 1.0]])
Q = Noise.from_cov(np.diag([0.04, 0.02, 0.01]))
R = np.array([[0.3, 0.05], [0.05, 0.2]])


def linear_motion() -> Transition:
    """v' = F v + u + B w on the vehicle; landmarks stay (any state width)."""
    def f(X, u, W):
        Y = X.copy()
        Y[:, :3] = X[:, :3] @ F.T + u + W @ B.T
        return Y

    def jac(x, u):
        Fj = np.eye(x.shape[0])
        Fj[:3, :3] = F
        G = np.zeros((x.shape[0], 3))
        G[:3] = B
        return Fj, G

    return Transition(f, Q, additive=False, jacobian=jac)


def linear_observation(slots) -> Measurement:
    """z_i = m_i - A p (A mixes in the heading): linear in vehicle and map."""
    slots = np.asarray(slots)
    A = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, -0.3]])

    def h(X):
        return np.hstack([X[:, 3 + 2 * s:5 + 2 * s] - X[:, :3] @ A.T for s in slots])

    def jac(x):
        H = np.zeros((2 * len(slots), x.shape[0]))
        for i, s in enumerate(slots):
            H[2 * i:2 * i + 2, :3] = -A
            H[2 * i:2 * i + 2, 3 + 2 * s:5 + 2 * s] = np.eye(2)
        return H

    return Measurement(h, Noise.from_cov(np.kron(np.eye(len(slots)), R)),
                       space=Euclidean(2 * len(slots)), jacobian=jac)


def linear_augmentation(n_lm: int, z) -> Transition:
    """m = p + z + v for each new landmark."""
    k = len(z) // 2

    def f(X, u, W):
        new = np.tile(X[:, :2], k) + u + W
        return np.hstack([X, new])

    def jac(x, u):
        n = x.shape[0]
        Fj = np.zeros((n + 2 * k, n))
        Fj[:n] = np.eye(n)
        G = np.zeros((n + 2 * k, 2 * k))
        for i in range(k):
            Fj[n + 2 * i:n + 2 * i + 2, :2] = np.eye(2)
            G[n + 2 * i:n + 2 * i + 2, 2 * i:2 * i + 2] = np.eye(2)
        return Fj, G

    return Transition(f, Noise.from_cov(np.kron(np.eye(k), R)), additive=False,
                      space=_space(n_lm + k), jacobian=jac)


def _run_ops(filt, local: bool):
    """predict, augment 2, predict x2, augment 1, update [1], predict x5, update [2, 0]
    (local mode defers the map's rank-3 update of each prediction: augmenting and
    updating a factor with deferred columns, and folding them after four predictions)."""
    b = filt.init(np.array([1.0, 2.0, 0.1]), _space(0), cov=np.diag([0.5, 0.4, 0.05]))
    mo = linear_motion()
    u = np.array([0.5, -0.2, 0.02])
    nis = []
    steps = filt.partitioned(LINEAR)

    def predict(b):
        return steps.predict(b, mo, u) if local else filt.predict(b, mo, u)

    def augment(b, n_lm, z):
        if local:
            return steps.augment(b, linear_augmentation(0, z), z)
        return filt.predict(b, linear_augmentation(n_lm, z), z)

    def update(b, slots, z):
        if local:
            b, inn = steps.update(b, np.array(slots), linear_observation(np.arange(len(slots))),
                                  z)
        else:
            b, inn = filt.update(b, linear_observation(slots), z)
        nis.append(inn.nis)
        return b

    b = predict(b)
    b = augment(b, 0, np.array([3.0, 1.0, -2.0, 4.0]))
    b = predict(predict(b))
    b = augment(b, 2, np.array([5.0, 5.0]))
    b = update(b, [1], np.array([-1.5, 3.5]))
    for _ in range(5):
        b = predict(b)
    b = update(b, [2, 0], np.array([3.2, 2.9, 1.1, -0.4]))
    return b, np.array(nis)


@pytest.mark.parametrize("name, params", CASES)
def test_local_equals_joint_on_a_model_linear_in_the_whole_state(name, params):
    filt = make(name, params)
    bj, nis_j = _run_ops(filt, local=False)
    bl, nis_l = _run_ops(filt, local=True)
    assert bl.dim == bj.dim == 9
    np.testing.assert_allclose(bl.mean, bj.mean, atol=1e-9)
    np.testing.assert_allclose(cov(bl), cov(bj), atol=1e-9)
    np.testing.assert_allclose(nis_l, nis_j, atol=1e-9)
    if name != "ekf":   # after an update the factor is square and lower triangular again
        assert bl.sqrt.shape == (9, 9) and np.allclose(np.triu(bl.sqrt, 1), 0.0)


# --------------------------------------------------------------------------- nonlinear

def _planar_belief(filt, n_lm: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    n = 3 + 2 * n_lm
    mean = np.concatenate([[2.0, 1.0, 0.4], rng.uniform(-15, 15, 2 * n_lm)])
    A = rng.normal(size=(n, n)) * np.r_[0.3, 0.3, 0.05, np.full(2 * n_lm, 0.4)][:, None]
    P = A @ A.T + 0.01 * np.eye(n)
    return filt.init(mean, PLANAR_LAYOUT.space_of(n_lm), cov=P)


def _dense_reference_predict(filt, b, model, u):
    """Textbook statistical linearisation of the vehicle block, carried to the map."""
    P, x = b.cov, b.mean
    bv = SqrtGaussian(x[:3], np.linalg.cholesky(P[:3, :3]), PLANAR_LAYOUT.space_of(0))
    X, W, dX, wm = draw(filt.rule, bv, model.noise)
    Y = model.f(X, u, W)[:, :3]
    sp = PLANAR_LAYOUT.space_of(0)
    ybar = sp.mean(Y, wm)
    fac = filt.rule.factor(np.hstack([dX, sp.local(ybar, Y)]))
    C = fac.C @ fac.C.T
    if fac.c0 is not None:
        C = C + fac.sign * np.outer(fac.c0, fac.c0)
    Pyv, Pyy = C[3:, :3], C[3:, 3:]
    A = Pyv @ np.linalg.inv(P[:3, :3])
    Pn = P.copy()
    Pn[:3, :3] = Pyy
    Pn[:3, 3:] = A @ P[:3, 3:]
    Pn[3:, :3] = Pn[:3, 3:].T
    return np.concatenate([ybar, x[3:]]), Pn


def _dense_reference_update(filt, b, slots, z):
    P, x = b.cov, b.mean
    rows = PLANAR_LAYOUT.rows(slots)
    sp = PLANAR_LAYOUT.space_of(len(slots))
    bs = SqrtGaussian(x[rows], np.linalg.cholesky(P[np.ix_(rows, rows)]), sp)
    model = observation_model(np.arange(len(slots)), np.diag([0.1, 0.02]) ** 2)
    X, _, dX, wm = draw(filt.rule, bs)
    Z = model.h(X)
    zhat = model.space.mean(Z, wm)
    fac = filt.rule.factor(np.hstack([dX, model.space.local(zhat, Z)]))
    C = fac.C @ fac.C.T
    if fac.c0 is not None:
        C = C + fac.sign * np.outer(fac.c0, fac.c0)
    ks = len(rows)
    Psz, Pzz = C[:ks, ks:], C[ks:, ks:] + model.noise.cov
    Pxz = P[:, rows] @ np.linalg.solve(P[np.ix_(rows, rows)], Psz)
    K = Pxz @ np.linalg.inv(Pzz)
    nu = model.space.local(zhat, z)
    return b.space.retract(x, K @ nu), P - K @ Pzz @ K.T


def _dense_reference_augment(filt, b, z):
    P, x = b.cov, b.mean
    model = augmentation_model(0, z, np.diag([0.1, 0.02]) ** 2)
    bv = SqrtGaussian(x[:3], np.linalg.cholesky(P[:3, :3]), PLANAR_LAYOUT.space_of(0))
    X, W, dX, wm = draw(filt.rule, bv, model.noise)
    Y = model.f(X, z, W)[:, 3:]
    ybar = wm @ Y
    fac = filt.rule.factor(np.hstack([dX, W, Y - ybar]))
    C = fac.C @ fac.C.T
    if fac.c0 is not None:
        C = C + fac.sign * np.outer(fac.c0, fac.c0)
    ka = 3 + len(z)
    A = C[ka:, :3] @ np.linalg.inv(P[:3, :3])
    n, m = len(x), len(z)
    Pn = np.zeros((n + m, n + m))
    Pn[:n, :n] = P
    Pn[n:, :n] = A @ P[:3]
    Pn[:n, n:] = Pn[n:, :n].T
    Pn[n:, n:] = C[ka:, ka:]
    return np.concatenate([x, ybar]), Pn


@pytest.mark.parametrize("name, params", [c for c in CASES if c[0] != "ekf"])
def test_local_steps_equal_dense_statistical_linearisation(name, params):
    filt = make(name, params)
    steps = filt.partitioned(PLANAR_LAYOUT)
    b = _planar_belief(filt, 4)
    mo = motion_model(0.025, 4.0, np.diag([0.3, np.radians(3.0)]) ** 2, 8)
    u = np.tile([3.0, 0.2], (8, 1))
    got = steps.predict(b, mo, u)
    mean, P = _dense_reference_predict(filt, b, mo, u)
    np.testing.assert_allclose(got.mean, mean, atol=1e-10)
    np.testing.assert_allclose(cov(got), P, atol=1e-10)

    z = np.array([8.0, 0.3, 12.0, -0.7])
    slots = np.array([3, 1])
    got, _ = steps.update(b, slots, observation_model(np.arange(2), np.diag([0.1, 0.02]) ** 2),
                          z)
    mean, P = _dense_reference_update(filt, b, slots, z)
    np.testing.assert_allclose(got.mean, mean, atol=1e-10)
    np.testing.assert_allclose(cov(got), P, atol=1e-10)

    z = np.array([6.0, 0.5, 9.0, -1.0])
    got = steps.augment(b, augmentation_model(0, z, np.diag([0.1, 0.02]) ** 2), z)
    mean, P = _dense_reference_augment(filt, b, z)
    assert got.dim == b.dim + 4
    np.testing.assert_allclose(got.mean, mean, atol=1e-10)
    np.testing.assert_allclose(cov(got), P, atol=1e-10)


@pytest.mark.parametrize("name, params", CASES)
def test_local_equals_joint_when_the_block_is_the_whole_state(name, params):
    """Nonlinear models; no landmarks outside the block: the same points, the same result."""
    filt = make(name, params)
    steps = filt.partitioned(PLANAR_LAYOUT)
    obs_cov = np.diag([0.1, 0.02]) ** 2
    b0 = _planar_belief(filt, 0)
    mo = motion_model(0.025, 4.0, np.diag([0.3, np.radians(3.0)]) ** 2, 4)
    u = np.tile([3.0, 0.2], (4, 1))
    pairs = [(steps.predict(b0, mo, u), filt.predict(b0, mo, u))]
    z = np.array([6.0, 0.5, 9.0, -1.0])
    pairs.append((steps.augment(b0, augmentation_model(0, z, obs_cov), z),
                  filt.predict(b0, augmentation_model(0, z, obs_cov), z)))
    b2 = _planar_belief(filt, 2, seed=3)
    z = np.array([8.0, 0.3, 12.0, -0.7])
    lo, inn_l = steps.update(b2, np.arange(2), observation_model(np.arange(2), obs_cov), z)
    jo, inn_j = filt.update(b2, observation_model(np.arange(2), obs_cov), z)
    pairs.append((lo, jo))
    assert abs(inn_l.nis - inn_j.nis) < 1e-9
    for lo, jo in pairs:
        np.testing.assert_allclose(lo.mean, jo.mean, atol=1e-10)
        np.testing.assert_allclose(cov(lo), cov(jo), atol=1e-10)


def test_cdkf_prediction_and_augmentation_equal_joint_on_the_nonlinear_model():
    """The central-difference step does not depend on the dimension, and joint-mode points
    along landmark columns leave the vehicle alone: the same quadrature in both modes."""
    filt = make("srcdkf", {})
    steps = filt.partitioned(PLANAR_LAYOUT)
    obs_cov = np.diag([0.1, 0.02]) ** 2
    b = _planar_belief(filt, 4)
    mo = motion_model(0.025, 4.0, np.diag([0.3, np.radians(3.0)]) ** 2, 8)
    u = np.tile([3.0, 0.2], (8, 1))
    z = np.array([6.0, 0.5])
    pairs = [(steps.predict(b, mo, u), filt.predict(b, mo, u)),
             (steps.augment(b, augmentation_model(0, z, obs_cov), z),
              filt.predict(b, augmentation_model(4, z, obs_cov), z))]
    for lo, jo in pairs:
        np.testing.assert_allclose(lo.mean, jo.mean, atol=1e-12)
        np.testing.assert_allclose(cov(lo), cov(jo), atol=1e-12)


# --------------------------------------------------------------------------- whole runs

@pytest.fixture(scope="module")
def planar_log():
    return simulate_planar(small_world(vehicle={"loops": 2}), np.random.default_rng(0))


def test_ekf_local_equals_joint_on_the_nonlinear_planar_run(planar_log):
    j = run_slam(planar_log, "ekf", mode="joint")
    lo = run_slam(planar_log, "ekf", mode="local")
    assert not j.diverged and not lo.diverged
    np.testing.assert_allclose(lo.poses, j.poses, atol=1e-9)
    np.testing.assert_allclose(lo.landmarks, j.landmarks, atol=1e-9)
    np.testing.assert_allclose(lo.pose_cov, j.pose_cov, atol=1e-9)
    np.testing.assert_allclose(lo.nis, j.nis, atol=1e-8)


@pytest.mark.parametrize("name", FILTERS[1:])
def test_sigma_point_local_and_joint_differ_by_millimetres(planar_log, name):
    """Not equal: joint mode applies the rule in the full dimension (wider spread)."""
    j = run_slam(planar_log, name, mode="joint")
    lo = run_slam(planar_log, name, mode="local")
    assert not j.diverged and not lo.diverged
    d = max(np.abs(lo.poses - j.poses).max(), np.abs(lo.landmarks - j.landmarks).max())
    assert 1e-7 < d < 5e-3


@pytest.mark.parametrize("name", FILTERS)
def test_local_mode_tracks_a_noise_free_log_exactly(name):
    log = simulate_planar(small_world(), np.random.default_rng(0), noise_scale=0.0)
    r = run_slam(log, name, noise_scale=1e-12, mode="local")
    assert not r.diverged, r.failure
    assert np.hypot(*(r.poses[:, :2] - log.truth[r.steps, :2]).T).max() < 1e-6
    assert np.linalg.norm(r.landmarks - log.landmarks[r.landmark_ids], axis=1).max() < 1e-6


def test_world_mode_selects_local_and_dense_filters_are_refused(planar_log):
    world = small_world(filters=("ekf", "srckf"), filter_options={"mode": "local"})
    assert world.filters.mode == "local"
    out = run_once(world, 0, np.random.SeedSequence(7), ["srckf"], reference=False)
    log = simulate_planar(world, np.random.default_rng(np.random.SeedSequence(7)))
    r = run_slam(log, "srckf", mode="local")
    assert out.scores["srckf"].lm_err.tolist() == pytest.approx(
        np.linalg.norm(r.landmarks - log.landmarks[r.landmark_ids], axis=1).tolist(), abs=0)
    with pytest.raises(WorldError, match="local mode supports"):
        small_world(filters=("ckf",), filter_options={"mode": "local"})
    with pytest.raises(ValueError, match="no local mode"):
        run_slam(planar_log, "ckf", mode="local")
    with pytest.raises(ValueError, match="unknown mode"):
        run_slam(planar_log, "ekf", mode="blocky")
