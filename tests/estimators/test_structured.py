"""The structured square-root sigma-point steps (:mod:`estimators.structured`) against the
dense steps they replace: equal to 1e-9 relative on random beliefs (single and batched, n up
to 101), on a factor of condition 1e12, and through their dense fallback."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import structured
from estimators.homm import HighOrderMoment
from estimators.linalg import NotPositiveDefiniteError, tria
from estimators.models import Measurement, Noise, SqrtGaussian, Transition
from estimators.rules import CentralDifference, Cubature, Unscented
from estimators.sigma import sigma_predict, sigma_update
from estimators.slam_group import SlamGroup
from estimators.spaces import Euclidean, Wrapped, wrap_angle
from estimators.structured import FALLBACKS, dense_steps

RULES = [Cubature(), Unscented(), Unscented(1.0, 0.0, "3-n"), Unscented(0.5, 2.0, 1.0),
         CentralDifference()]
H, Q = 3, 4


def _f(X, u, W):
    """A car-like move of the first three rows driven by the noise; the rest copied."""
    Y = X.copy()
    Y[..., 0] = X[..., 0] + np.cos(X[..., 2] + W[..., 0]) * (1.0 + W[..., 1])
    Y[..., 1] = X[..., 1] + np.sin(X[..., 2] + W[..., 2]) * (1.0 + 0.3 * W[..., 3])
    Y[..., 2] = wrap_angle(X[..., 2] + 0.1 * W[..., 1] + 0.2 * np.sin(X[..., 0]))
    return Y


def _motion(moves: int | None = H) -> Transition:
    rng = np.random.default_rng(7)
    Sq = np.tril(rng.normal(size=(Q, Q))) * 0.1 + 0.2 * np.eye(Q)
    return Transition(_f, Noise.from_sqrt(Sq), additive=False, moves=moves)


def _observation(slots: list[int], declared: bool = True) -> Measurement:
    s = np.asarray(slots)

    def h(X):
        dx, dy = X[..., 3 + 2 * s] - X[..., :1], X[..., 4 + 2 * s] - X[..., 1:2]
        Z = np.empty(X.shape[:-1] + (2 * len(s),))
        Z[..., 0::2] = np.hypot(dx, dy)
        Z[..., 1::2] = wrap_angle(np.arctan2(dy, dx) - X[..., 2:3])
        return Z

    reads = (0, 1, 2, *[r for i in slots for r in (3 + 2 * i, 4 + 2 * i)])
    return Measurement(h, Noise.from_sigmas(np.tile([0.1, 0.05], len(s))),
                       Wrapped(2 * len(s), tuple(range(1, 2 * len(s), 2))),
                       reads=reads if declared else None)


def _belief(n: int, batch: int | None, rng: np.random.Generator,
            cond: float | None = None) -> SqrtGaussian:
    lead = () if batch is None else (batch,)
    if cond is None:
        S = np.tril(rng.normal(size=lead + (n, n))) * 0.3
        i = np.arange(n)
        S[..., i, i] = np.abs(S[..., i, i]) + 0.2
    else:  # singular values of the factor from 1 to 1/sqrt(cond), random directions
        U, _ = np.linalg.qr(rng.normal(size=(n, n)))
        S = tria(U * np.logspace(0.0, -0.5 * np.log10(cond), n))
        S = np.broadcast_to(S, lead + (n, n)).copy()
    mean = rng.normal(size=lead + (n,)) * 3.0
    return SqrtGaussian(mean, S, Wrapped(n, (2,)))


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _both(step, *args):
    out = step(*args)
    with dense_steps():
        ref = step(*args)
    return out, ref


def _lower_positive(S) -> bool:
    d = np.diagonal(S, axis1=-2, axis2=-1)
    return bool(np.all(np.triu(S, 1) == 0.0) and np.all(d > 0.0))


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
@pytest.mark.parametrize("n,batch", [(3, None), (23, None), (23, 3), (101, None), (61, 2)])
def test_predict_equals_dense(rule, n, batch):
    rng = np.random.default_rng(n + (batch or 0))
    b = _belief(n, batch, rng)
    out, ref = _both(sigma_predict, rule, "sqrt", b, _motion(), None)
    assert _rel(out.mean, ref.mean) < 1e-9
    assert _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(out.cov, ref.cov) < 1e-9
    assert _lower_positive(out.sqrt)


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
@pytest.mark.parametrize("n,batch,slots", [(13, None, [1, 3]), (23, 3, [0, 4]),
                                           (101, None, [7, 20, 11]), (61, 2, [28])])
def test_update_equals_dense(rule, n, batch, slots):
    rng = np.random.default_rng(n)
    b = _belief(n, batch, rng)
    model = _observation(slots)
    z = model.h(b.mean[..., None, :])[..., 0, :] + 0.05
    try:
        ref, ref_inn = _run_dense(sigma_update, rule, "sqrt", b, model, z)
    except NotPositiveDefiniteError:  # (Julier's set: the dense step's own downdate fails)
        with pytest.raises(NotPositiveDefiniteError):
            sigma_update(rule, "sqrt", b, model, z)
        return
    out, inn = sigma_update(rule, "sqrt", b, model, z)
    assert _rel(out.mean, ref.mean) < 1e-9
    assert _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(np.asarray(inn.nis), np.asarray(ref_inn.nis)) < 1e-9
    assert _rel(inn.sqrt_cov, ref_inn.sqrt_cov) < 1e-9
    assert _lower_positive(out.sqrt)


def _run_dense(step, *args):
    with dense_steps():
        return step(*args)


@pytest.mark.parametrize("rule", [Cubature(), CentralDifference()], ids=lambda r: r.name)
def test_condition_1e12_factor(rule):
    rng = np.random.default_rng(3)
    n = 41
    b = _belief(n, None, rng, cond=1e12)
    assert np.linalg.cond(b.cov) > 1e11
    pred, pref = _both(sigma_predict, rule, "sqrt", b, _motion(), None)
    assert _lower_positive(pred.sqrt)
    assert _rel(pred.cov, pref.cov) < 1e-9
    model = _observation([2, 9])
    z = model.h(pred.mean[None, :])[0] + 0.02
    (post, _), (dref, _) = _both(sigma_update, rule, "sqrt", pred, model, z)
    assert _lower_positive(post.sqrt)
    assert _rel(post.cov, dref.cov) < 1e-9
    assert _rel(post.mean, dref.mean) < 1e-9


def test_update_fallback_is_counted_and_dense():
    """A measurement so exact that I - WWᵀ is singular in floating point: the Potter
    factor fails, the dense step (which cannot fail there) is taken, and it is counted."""
    n = 9
    rng = np.random.default_rng(5)
    b = _belief(n, None, rng)
    b = SqrtGaussian(b.mean, b.sqrt, Euclidean(n))
    model = Measurement(lambda X: X[..., :1], Noise.from_sigmas([1e-30]), reads=(0,))
    FALLBACKS.clear()
    out, _ = sigma_update(Cubature(), "sqrt", b, model, b.mean[:1] + 0.1)
    assert sum(FALLBACKS.values()) == 1 and all(k.startswith("update") for k in FALLBACKS)
    ref, _ = _run_dense(sigma_update, Cubature(), "sqrt", b, model, b.mean[:1] + 0.1)
    np.testing.assert_array_equal(out.sqrt, ref.sqrt)
    np.testing.assert_array_equal(out.mean, ref.mean)


def test_predict_fallback_on_a_failing_centre_downdate():
    """The unscented set with a large negative centre weight: the structured factor's
    downdate fails, counted, and the dense step then fails the same way."""
    rule = Unscented(1.0, -5.0, -20.0)
    rng = np.random.default_rng(11)
    b = _belief(23, None, rng)
    FALLBACKS.clear()
    with pytest.raises(NotPositiveDefiniteError):
        sigma_predict(rule, "sqrt", b, _motion(), None)
    assert sum(FALLBACKS.values()) == 1
    with pytest.raises(NotPositiveDefiniteError), dense_steps():
        sigma_predict(rule, "sqrt", b, _motion(), None)


def test_undeclared_or_unsupported_take_the_dense_step():
    rng = np.random.default_rng(2)
    b = _belief(13, None, rng)
    assert structured.predict(Cubature(), b, _motion(None), None) is None
    hm = HighOrderMoment()
    assert structured.predict(hm, b, _motion(), None) is None
    group = SqrtGaussian(b.mean, b.sqrt, SlamGroup(5))
    assert structured.predict(Cubature(), group, _motion(), None) is not None
    full = SqrtGaussian(b.mean, b.sqrt + np.triu(np.ones((13, 13)), 1), SlamGroup(5))
    assert structured.predict(Cubature(), full, _motion(), None) is None  # not triangular
    with dense_steps():
        assert structured.predict(Cubature(), b, _motion(), None) is None


def test_a_wrong_declaration_is_refused():
    def moves_tail(X, u, W):
        Y = _f(X, u, W)
        Y[..., 5] += 1.0
        return Y

    model = Transition(moves_tail, _motion().noise, additive=False, moves=H)
    b = _belief(13, None, np.random.default_rng(4))
    with pytest.raises(ValueError, match="moves=3"):
        sigma_predict(Cubature(), "sqrt", b, model, None)
    with pytest.raises(ValueError, match="moves"):
        Transition(_f, _motion().noise, additive=False, moves=0)
    with pytest.raises(ValueError, match="reads"):
        Measurement(lambda X: X[..., :1], Noise.from_sigmas([1.0]), reads=(-1,))


@pytest.mark.parametrize("batch", [None, 3])
def test_ekf_steps_equal_dense(batch):
    """The EKF with the planar car model's declared static tail and the range-bearing
    model's declared rows: the dense (Joseph-form) steps' values to 1e-9 relative."""
    from estimators.ekf import ekf_predict, ekf_update
    from estimators.models import Gaussian
    from slam.kinds.planar.models import motion_model, observation_model

    rng = np.random.default_rng(8)
    sb = _belief(41, batch, rng)
    b = Gaussian(sb.mean, sb.cov, sb.space)
    model = motion_model(0.025, 4.0, np.diag([0.09, 0.003]), 8)
    assert model.moves == 3
    u = np.broadcast_to([3.0, 0.1], (() if batch is None else (batch,)) + (8, 2))
    pred, pref = _both(ekf_predict, b, model, u)
    assert _rel(pred.cov, pref.cov) < 1e-9 and _rel(pred.mean, pref.mean) < 1e-9
    obs = observation_model(np.array([3, 10, 17]), np.diag([0.01, 3e-4]))
    z = obs.h(pred.mean[..., None, :])[..., 0, :] + 0.03
    (post, inn), (dref, dinn) = _both(ekf_update, pred, obs, z)
    assert _rel(post.cov, dref.cov) < 1e-9 and _rel(post.mean, dref.mean) < 1e-9
    assert _rel(np.asarray(inn.nis), np.asarray(dinn.nis)) < 1e-9
    assert np.array_equal(post.cov, np.swapaxes(post.cov, -1, -2))


def test_invariant_variants_keep_their_declarations():
    """The motion still moves only the pose's ambient coordinates and ``h`` reads the same
    ambient rows (``SlamGroup.prefix_rows``); the structured steps take the group's form."""
    from slam.kinds.planar.models import motion_model, observation_model
    from slam.kinds.planar.variants import invariant_motion, invariant_observation

    m = motion_model(0.025, 4.0, np.diag([0.09, 0.003]), 2)
    o = observation_model(np.array([0, 2]), np.diag([0.01, 3e-4]))
    assert m.moves == 3 and o.reads == (0, 1, 2, 3, 4, 7, 8)
    assert invariant_motion(m, "right").moves == 3
    assert invariant_observation(o, "right").reads == o.reads


@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("batch", [None, 2])
def test_update_on_the_slam_group_equals_dense(side, batch):
    rng = np.random.default_rng(12)
    b = _belief(23, batch, rng)
    b = SqrtGaussian(b.mean, b.sqrt, SlamGroup(10, side))
    model = _observation([2, 5])
    z = model.h(b.mean[..., None, :])[..., 0, :] + 0.02
    (out, inn), (ref, rinn) = _both(sigma_update, Cubature(), "sqrt", b, model, z)
    assert _rel(out.mean, ref.mean) < 1e-9 and _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(np.asarray(inn.nis), np.asarray(rinn.nis)) < 1e-9
    assert _lower_positive(out.sqrt)


def _group_belief(side: str, batch: int | None, rng: np.random.Generator,
                  cond: float | None = None) -> SqrtGaussian:
    b = _belief(23, batch, rng, cond)
    return SqrtGaussian(b.mean * 5.0, b.sqrt, SlamGroup(10, side))


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("batch", [None, 2])
def test_predict_on_the_slam_group_equals_dense(rule, side, batch):
    """The group form of the structured prediction (a map point's deviation is ℓ ± c a⊙S_k)
    against the dense step: the generic moved-pose model and the planar car model."""
    from slam.kinds.planar.models import motion_model
    from slam.kinds.planar.variants import invariant_motion

    rng = np.random.default_rng(21)
    b = _group_belief(side, batch, rng)
    car = invariant_motion(motion_model(0.025, 4.0, np.diag([0.09, 0.003]), 8), side)
    u = np.broadcast_to([3.0, 0.1], (() if batch is None else (batch,)) + (8, 2))
    for model, inputs in ((_motion(), None), (car, u)):
        FALLBACKS.clear()
        assert structured.predict(rule, b, model, inputs) is not None or FALLBACKS
        try:
            ref = _run_dense(sigma_predict, rule, "sqrt", b, model, inputs)
        except NotPositiveDefiniteError:  # a negative centre weight's downdate, both fail
            with pytest.raises(NotPositiveDefiniteError):
                sigma_predict(rule, "sqrt", b, model, inputs)
            continue
        out = sigma_predict(rule, "sqrt", b, model, inputs)
        assert _rel(out.mean, ref.mean) < 1e-9
        assert _rel(out.sqrt, ref.sqrt) < 1e-9
        assert _rel(out.cov, ref.cov) < 1e-9
        assert _lower_positive(out.sqrt)


@pytest.mark.parametrize("rule", [Cubature(), CentralDifference()], ids=lambda r: r.name)
@pytest.mark.parametrize("side", ["right", "left"])
def test_group_predict_condition_1e12(rule, side):
    rng = np.random.default_rng(4)
    b = _group_belief(side, None, rng, cond=1e12)
    assert np.linalg.cond(b.cov) > 1e11
    FALLBACKS.clear()
    out, ref = _both(sigma_predict, rule, "sqrt", b, _motion(), None)
    assert not FALLBACKS
    assert _lower_positive(out.sqrt)
    assert _rel(out.cov, ref.cov) < 1e-9
    assert _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(out.mean, ref.mean) < 1e-9
