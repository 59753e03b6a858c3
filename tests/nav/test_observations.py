"""nav.observations: bit-for-bit equal to the star-sensor kind's former ``star_measurement``
for scalar sigma; every analytic Jacobian against a central difference through retract."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from numpy.typing import ArrayLike

from estimators import Euclidean, Measurement, Noise, Product, make_filter
from nav.observations import (
    direction_measurement,
    magnetometer_measurement,
    quaternion_measurement,
)
from nav.quaternion import qconj, qexp, qmul, qrotate, skew
from nav.spaces import UnitQuaternion

STATE = Product([UnitQuaternion(), Euclidean(3)])
SIGMA = 20.0 / 3600.0 * np.pi / 180.0  # 20 arcsec


def _ref_star_measurement(mode: str, sigma: float, refs: np.ndarray | None = None
                          ) -> Measurement:
    """Frozen copy of the star-sensor kind's measurement before it moved to
    nav.observations, so the exact operation order stays pinned."""
    if mode == "quaternion":
        H = np.hstack([np.eye(3), np.zeros((3, 3))])
        return Measurement(lambda X: X[:, :4], Noise.from_sigmas(np.full(3, sigma)),
                           UnitQuaternion(), jacobian=lambda x: H)
    refs = np.asarray(refs, dtype=np.float64).reshape(-1, 3)
    k = refs.shape[0]

    def h(X: np.ndarray) -> np.ndarray:
        return qrotate(qconj(X[:, None, :4]), refs[None, :, :]).reshape(X.shape[0], 3 * k)

    def jac(x: np.ndarray) -> np.ndarray:
        b = qrotate(qconj(x[None, :4]), refs)
        return np.hstack([skew(b).reshape(3 * k, 3), np.zeros((3 * k, 3))])

    return Measurement(h, Noise.from_sigmas(np.full(3 * k, sigma)), Euclidean(3 * k),
                       jacobian=jac)


def same_bits(a: ArrayLike, b: ArrayLike) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return (a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b)
            and a.tobytes() == b.tobytes())


def unit(v: ArrayLike) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.fixture
def states() -> np.ndarray:
    """13 states [q, b] with well spread attitudes and non-zero biases."""
    rng = np.random.default_rng(11)
    return np.hstack([unit(rng.normal(size=(13, 4))), rng.normal(scale=0.01, size=(13, 3))])


REFS = unit(np.array([[0.3, -0.5, 0.81], [-0.7, 0.2, 0.1]]))


def assert_same_model(mine: Measurement, theirs: Measurement, X: np.ndarray) -> None:
    assert type(mine.space) is type(theirs.space) and mine.space.dim == theirs.space.dim
    assert same_bits(mine.noise.cov, theirs.noise.cov)
    assert same_bits(mine.noise.sqrt, theirs.noise.sqrt)
    assert same_bits(mine.h(X), theirs.h(X))
    for x in X[:3]:
        assert same_bits(mine.jacobian(x), theirs.jacobian(x))


@pytest.mark.parametrize("sigma", [SIGMA, 1e-3, 0.2])
def test_quaternion_bits_match_star_measurement(states: np.ndarray, sigma: float) -> None:
    theirs = _ref_star_measurement("quaternion", sigma)
    assert_same_model(quaternion_measurement(sigma), theirs, states)


@pytest.mark.parametrize("sigma", [SIGMA, 0.2])
@pytest.mark.parametrize("k", [1, 2])
def test_direction_bits_match_star_measurement(states: np.ndarray, sigma: float, k: int) -> None:
    theirs = _ref_star_measurement("vector", sigma, REFS[:k])
    assert_same_model(direction_measurement(REFS[:k], sigma), theirs, states)


def central_difference(meas: Measurement, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """dz/dδ at x: (h(x ⊞ εe_i) ⊟ h(x) - h(x ⊞ -εe_i) ⊟ h(x)) / 2ε, δ on STATE's tangent."""
    z0 = meas.h(x[None])[0]
    cols = []
    for i in range(STATE.dim):
        d = np.zeros(STATE.dim)
        d[i] = eps
        zp = meas.h(STATE.retract(x, d)[None])[0]
        zm = meas.h(STATE.retract(x, -d)[None])[0]
        cols.append((meas.space.local(z0, zp) - meas.space.local(z0, zm)) / (2.0 * eps))
    return np.array(cols).T


MODELS = {
    "quaternion": lambda: quaternion_measurement([1e-3, 2e-3, 5e-3]),
    "one direction": lambda: direction_measurement(REFS[0], 0.01),
    "two directions": lambda: direction_measurement(REFS, [[0.2], [0.1]]),
    "magnetometer nT": lambda: magnetometer_measurement([21000.0, -1500.0, 43000.0], 100.0),
    "magnetometer unit": lambda: magnetometer_measurement(unit([1.0, 0.0, 1.0]), 0.01),
}


@pytest.mark.parametrize("name", list(MODELS))
def test_jacobian_matches_central_difference(states: np.ndarray, name: str) -> None:
    meas = MODELS[name]()
    for x in states:
        H = meas.jacobian(x)
        assert H.shape == (meas.space.dim, STATE.dim)
        assert np.all(H[:, 3:] == 0.0)  # the bias does not enter
        scale = max(1.0, float(np.max(np.abs(H))))
        np.testing.assert_allclose(H, central_difference(meas, x), rtol=0, atol=1e-8 * scale)


def test_models_predict_the_right_readings(states: np.ndarray) -> None:
    x = states[0]
    C_T = lambda v: qrotate(qconj(x[:4]), v)  # noqa: E731  body-frame image of v
    np.testing.assert_array_equal(quaternion_measurement(0.1).h(states), states[:, :4])
    np.testing.assert_allclose(direction_measurement(REFS, 0.1).h(x[None])[0],
                               np.concatenate([C_T(r) for r in REFS]), atol=1e-15)
    m = np.array([21000.0, -1500.0, 43000.0])
    z = magnetometer_measurement(m, 50.0).h(states)
    np.testing.assert_allclose(z[0], C_T(m), rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(z, axis=1), np.linalg.norm(m), rtol=1e-14)
    # the quaternion innovation is the body-frame rotation vector
    d = np.array([1e-3, -2e-3, 3e-3])
    nu = UnitQuaternion().local(x[:4], qmul(x[:4], qexp(d)))
    np.testing.assert_allclose(nu, d, atol=1e-15)


def test_per_axis_and_per_reference_sigma() -> None:
    q = quaternion_measurement([1.0, 2.0, 3.0]).noise
    np.testing.assert_array_equal(np.diag(q.cov), [1.0, 4.0, 9.0])
    axes = direction_measurement(REFS, [0.1, 0.2, 0.3]).noise.sqrt
    np.testing.assert_array_equal(np.diag(axes), [0.1, 0.2, 0.3, 0.1, 0.2, 0.3])
    per_ref = direction_measurement(REFS, [[0.2], [0.1]]).noise.sqrt
    np.testing.assert_array_equal(np.diag(per_ref), [0.2] * 3 + [0.1] * 3)
    full = direction_measurement(REFS, [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]).noise.cov
    np.testing.assert_array_equal(np.diag(full), np.arange(1.0, 7.0) ** 2)
    mag = magnetometer_measurement([1.0, 2.0, 3.0], [10.0, 20.0, 30.0]).noise.sqrt
    np.testing.assert_array_equal(np.diag(mag), [10.0, 20.0, 30.0])
    assert quaternion_measurement(0.1, rest_dim=0).jacobian(np.r_[1.0, 0, 0, 0]).shape == (3, 3)


@pytest.mark.parametrize("make", [
    lambda: direction_measurement([1.0, 1.0, 0.0], 0.1),  # not a unit vector
    lambda: direction_measurement(REFS, [0.1, 0.2]),  # does not broadcast to (2, 3)
    lambda: direction_measurement(REFS, 0.0),
    lambda: quaternion_measurement([0.1, 0.1]),
    lambda: magnetometer_measurement([0.0, 0.0, 0.0], 1.0),
    lambda: magnetometer_measurement([np.inf, 0.0, 0.0], 1.0),
])
def test_invalid_arguments_raise(make: Callable[[], object]) -> None:
    with pytest.raises(ValueError):
        make()


@pytest.mark.parametrize("filter_name", ["ekf", "srckf"])
def test_update_with_two_directions_recovers_attitude(filter_name: str) -> None:
    """One two-direction update (σ = 1e-3 rad) from a 2° error lands within 0.05° of the
    truth (measured: 0.007° for both filters)."""
    truth = unit([0.9, 0.1, -0.3, 0.2])
    err0 = np.radians([1.5, -1.0, 0.8])
    x0 = np.r_[qmul(truth, qexp(-err0)), np.zeros(3)]
    meas = direction_measurement(REFS, 1e-3)
    z = meas.h(np.r_[truth, np.zeros(3)][None])[0]
    flt = make_filter(filter_name)
    belief = flt.init(x0, STATE, cov=np.diag([np.radians(3.0) ** 2] * 3 + [1e-6] * 3))
    post, inn = flt.update(belief, meas, z)
    err = UnitQuaternion().local(post.mean[:4], truth)
    assert np.degrees(np.linalg.norm(err)) < 0.05
    assert np.isfinite(inn.nis)
