"""The iterated filters (:mod:`estimators.iterated`): with one iteration each is its
one-pass twin; on a linear model they are the Kalman filter (``test_filters.py`` runs every
name in ``FILTER_NAMES``); on a strongly nonlinear measurement the iterated EKF reaches the
MAP estimate (checked against a direct minimisation), on a flat space and on the unit
quaternions; the iterated sigma-point update moves towards the true posterior mean."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from estimators import Euclidean, Measurement, Noise, Product, Transition, Wrapped, make_filter
from nav.spaces import UnitQuaternion

SPACE = Wrapped(4, (2,))
TWINS = [("iekf", "ekf", {}), ("isrckf", "srckf", {}),
         ("isrukf", "srukf", {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"})]


def _h(X):
    dx, dy = 10.0 - X[..., 0], 5.0 - X[..., 1]
    b = np.mod(np.arctan2(dy, dx) - X[..., 2] + np.pi, 2 * np.pi) - np.pi
    return np.stack([np.hypot(dx, dy), b], axis=-1)


MEAS = Measurement(_h, Noise.from_sigmas([0.1, 0.02]), Wrapped(2, (1,)))
TRANS = Transition(lambda X, u: X + u, Noise.from_sigmas([0.05, 0.05, 0.01, 0.02]))


@pytest.mark.parametrize(("iterated", "twin", "settings"), TWINS)
def test_one_iteration_is_the_one_pass_twin(iterated, twin, settings):
    it = make_filter(iterated, iterations=1, **settings)
    one = make_filter(twin, **settings)
    rng = np.random.default_rng(2)
    b_it = it.init(np.array([1.0, 0.5, 0.3, 1.0]), SPACE, cov=np.diag([1.0, 1.0, 0.2, 0.1]))
    b_one = one.init(b_it.mean, SPACE, cov=b_it.cov)
    for _ in range(20):
        u = rng.normal(0, 0.1, 4)
        z = np.array([rng.uniform(8, 12), rng.uniform(-2, 2)])
        b_it, i_it = it.update(it.predict(b_it, TRANS, u), MEAS, z)
        b_one, i_one = one.update(one.predict(b_one, TRANS, u), MEAS, z)
        np.testing.assert_allclose(b_it.mean, b_one.mean, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(b_it.cov, b_one.cov, rtol=1e-9, atol=1e-13)
        assert i_it.nis == pytest.approx(i_one.nis, rel=1e-9)


def _map(cost, x0):
    res = minimize(cost, x0, method="BFGS", options={"gtol": 1e-12, "maxiter": 2000})
    return res.x


def test_the_iterated_ekf_reaches_the_map_of_a_strongly_nonlinear_measurement():
    """Prior N(0, 1) on x, z = x³ + v with σ_v = 0.1 and z = 8: the one-pass EKF's
    linearisation at 0 has slope 0; the MAP is near x = 2."""
    space = Euclidean(1)
    meas = Measurement(lambda X: X**3, Noise.from_sigmas([0.1]),
                       jacobian=lambda x: np.array([[3.0 * x[0] ** 2]]))
    prior = make_filter("iekf").init(np.array([0.5]), space, cov=np.array([[1.0]]))
    z = np.array([8.0])

    def cost(x):
        return 0.5 * ((z[0] - x[0] ** 3) / 0.1) ** 2 + 0.5 * (x[0] - 0.5) ** 2

    x_map = _map(cost, np.array([2.0]))
    post, _ = make_filter("iekf", iterations=50, tolerance=1e-12).update(prior, meas, z)
    one, _ = make_filter("ekf").update(prior, meas, z)
    assert abs(post.mean[0] - x_map[0]) < 1e-6
    assert abs(one.mean[0] - x_map[0]) > 0.1  # the one-pass update is far from it


def test_the_iterated_ekf_reaches_the_map_on_the_unit_quaternions():
    """A 40° prior error about z, observed through one body-frame direction: the MAP over
    the rotation-vector chart of the prior, minimised directly, is the iterated EKF's."""
    quat = UnitQuaternion()
    space = Product([quat, Euclidean(1)])
    ref = np.array([1.0, 0.0, 0.0])

    def h(X):
        from nav.quaternion import qconj, qmul

        q = X[..., :4]
        v = np.concatenate([np.zeros(X.shape[:-1] + (1,)), np.broadcast_to(ref, X.shape[:-1]
                                                                           + (3,))], axis=-1)
        return qmul(qmul(qconj(q), v), q)[..., 1:]

    sig = 0.05
    meas = Measurement(h, Noise.from_sigmas([sig] * 3))
    x0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0])
    P = np.diag([0.3, 0.3, 0.5, 1.0]) ** 2
    prior = make_filter("iekf").init(x0, space, cov=P)
    ang = np.radians(40.0)
    z = np.array([np.cos(ang), -np.sin(ang), 0.0])

    def cost(d):
        r = z - h(space.retract(x0, d[None]))[0]
        return 0.5 * r @ r / sig**2 + 0.5 * d @ np.linalg.solve(P, d)

    d_map = _map(cost, np.array([0.0, 0.0, -0.6, 0.0]))
    post, _ = make_filter("iekf", iterations=50, tolerance=1e-12).update(prior, meas, z)
    d_post = space.local(x0, post.mean)
    np.testing.assert_allclose(d_post, d_map, atol=1e-6)


def test_the_iterated_sigma_point_update_moves_towards_the_posterior_mean():
    """The same cubic case: the posterior mean by quadrature; the iterated SRCKF is closer
    to it than the one-pass SRCKF (posterior linearisation converges to a Gaussian fit of
    the posterior, not to the MAP)."""
    space = Euclidean(1)
    meas = Measurement(lambda X: X**3, Noise.from_sigmas([0.5]))
    z = np.array([8.0])
    xs = np.linspace(-6, 6, 200_001)
    logp = -0.5 * ((z[0] - xs**3) / 0.5) ** 2 - 0.5 * (xs - 0.5) ** 2
    p = np.exp(logp - logp.max())
    mean = float(np.sum(xs * p) / np.sum(p))
    prior = make_filter("srckf").init(np.array([0.5]), space, cov=np.array([[1.0]]))
    one, _ = make_filter("srckf").update(prior, meas, z)
    it, _ = make_filter("isrckf", iterations=30, tolerance=1e-12).update(prior, meas, z)
    assert abs(it.mean[0] - mean) < 0.5 * abs(one.mean[0] - mean)


@pytest.mark.parametrize("name", ["iekf", "isrckf"])
def test_iterated_settings_are_validated(name):
    with pytest.raises(ValueError, match="iterations"):
        make_filter(name, iterations=0)
    with pytest.raises(ValueError, match="tolerance"):
        make_filter(name, tolerance=-1.0)
