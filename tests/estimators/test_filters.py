"""The filter core against closed-form references.

* every filter reduces to the Kalman filter on a linear-Gaussian model;
* every square-root / SVD filter equals its dense twin on a nonlinear model;
* the dense UKF equals filterpy's UnscentedKalmanFilter;
* the square-root form survives conditioning that breaks the dense form.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    FILTER_NAMES,
    ROBUST_FILTER_NAMES,
    Angle,
    Cubature,
    Euclidean,
    Measurement,
    Noise,
    NotPositiveDefiniteError,
    Product,
    SqrtGaussian,
    Transition,
    Unscented,
    make_filter,
    settings_for,
)
from estimators.linearise import numerical_jacobian
from estimators.sigma import SigmaPointFilter
from tests.linear_model import B, F, H, Q, R, linear_models, simulate_linear


# --------------------------------------------------------------------------- linear model
def kalman_reference(x0, P0, us, zs):
    """Textbook Kalman filter (covariance form), written out independently."""
    x, P, out = x0.copy(), P0.copy(), []
    for u, z in zip(us, zs):
        x = F @ x + B @ u
        P = F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        nu = z - H @ x
        x = x + K @ nu
        P = (np.eye(4) - K @ H) @ P
        out.append((x.copy(), P.copy(), float(nu @ np.linalg.solve(S, nu))))
    return out


@pytest.mark.parametrize("name", FILTER_NAMES)
def test_linear_gaussian_reduces_to_kalman(name):
    us, zs = simulate_linear(200, seed=1)
    x0, P0 = np.zeros(4), np.diag([1.0, 2.0, 0.5, 1.5])
    ref = kalman_reference(x0, P0, us, zs)
    filt = make_filter(name)
    tr, me = linear_models(with_jacobians=True)
    b = filt.init(x0, Euclidean(4), cov=P0)
    for (u, z), (xr, Pr, nis_r) in zip(zip(us, zs), ref):
        b = filt.predict(b, tr, u)
        b, inn = filt.update(b, me, z)
        np.testing.assert_allclose(b.mean, xr, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.cov, Pr, rtol=1e-9, atol=1e-13)
        assert inn.nis == pytest.approx(nis_r, rel=1e-9)


@pytest.mark.parametrize("name", FILTER_NAMES + ROBUST_FILTER_NAMES)
def test_a_semidefinite_prior_is_accepted_and_a_negative_one_refused(name):
    """A state component known exactly (variance 0, or a σ whose square underflows) is a
    valid prior: every filter starts from it and still equals the Kalman filter; a
    covariance with a clearly negative eigenvalue raises."""
    us, zs = simulate_linear(50, seed=2)
    x0, P0 = np.zeros(4), np.diag([0.0, 2.0, (5e-324) ** 2, 1.5])
    ref = kalman_reference(x0, P0, us, zs)
    filt = make_filter(name, **settings_for(name, {"gamma": np.inf}))
    tr, me = linear_models(with_jacobians=True)
    b = filt.init(x0, Euclidean(4), cov=P0)
    np.testing.assert_allclose(b.cov, P0, atol=1e-15)
    for u, z in zip(us, zs):
        b, _ = filt.update(filt.predict(b, tr, u), me, z)
    xr, Pr, _ = ref[-1]
    np.testing.assert_allclose(b.mean, xr, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(b.cov, Pr, rtol=1e-8, atol=1e-12)
    with pytest.raises(NotPositiveDefiniteError):
        filt.init(x0, Euclidean(4), cov=np.diag([1.0, -1e-3, 1.0, 1.0]))


def test_ekf_numerical_jacobian_matches_analytic_on_linear_model():
    us, zs = simulate_linear(200, seed=2)
    ekf = make_filter("ekf")
    analytic, numeric = linear_models(True), linear_models(False)
    a = n = ekf.init(np.zeros(4), Euclidean(4), cov=np.eye(4))
    for u, z in zip(us, zs):
        a, _ = ekf.update(ekf.predict(a, analytic[0], u), analytic[1], z)
        n, _ = ekf.update(ekf.predict(n, numeric[0], u), numeric[1], z)
    # central differences with eps = 1e-6 carry ~1e-16 / 1e-6 = 1e-10 rounding per entry
    np.testing.assert_allclose(n.mean, a.mean, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(n.cov, a.cov, rtol=1e-7, atol=1e-9)


def test_numerical_jacobian_through_angle_space():
    # h(x) = [range, bearing] from a pose x = [px, py, phi] to the origin
    def h(X, W=None):
        dx, dy = -X[:, 0], -X[:, 1]
        return np.column_stack([np.hypot(dx, dy), np.arctan2(dy, dx) - X[:, 2]])

    space = Product([Euclidean(2), Angle()])
    zspace = Product([Euclidean(1), Angle()])
    x = np.array([3.0, -4.0, np.pi - 1e-7])  # heading next to the wrap
    J, _ = numerical_jacobian(h, x, space, zspace)
    # r = |p|, b = atan2(-py, -px) - phi: dr/dp = p/r, db/dp = [-py, px]/r², db/dphi = -1
    expected = np.array([[3.0 / 5.0, -4.0 / 5.0, 0.0],
                         [4.0 / 25.0, 3.0 / 25.0, -1.0]])
    np.testing.assert_allclose(J, expected, atol=1e-8)


# --------------------------------------------------------------------------- nonlinear model
def nonlinear_models():
    """A 3-D nonlinear oscillator with a range-like measurement (no angles)."""
    dt = 0.1

    def f(X, u):
        x, v, a = X[:, 0], X[:, 1], X[:, 2]
        return np.column_stack([x + dt * v, v + dt * (-a * np.sin(x) - 0.1 * v), a])

    def h(X):
        return np.column_stack([np.sqrt(1.0 + X[:, 0] ** 2), X[:, 0] * X[:, 1]])

    return (Transition(f, Noise.from_cov(np.diag([1e-4, 1e-3, 1e-5]))),
            Measurement(h, Noise.from_cov(np.diag([0.05, 0.02]))))


def nonlinear_data(n_steps: int, seed: int):
    tr, me = nonlinear_models()
    rng = np.random.default_rng(seed)
    x = np.array([[0.8, 0.0, 1.5]])
    zs = []
    for _ in range(n_steps):
        x = tr.f(x, None) + rng.multivariate_normal(np.zeros(3), tr.noise.cov)
        zs.append(me.h(x)[0] + rng.multivariate_normal(np.zeros(2), me.noise.cov))
    return zs


TWINS = [
    ("srckf", "ckf", {}),
    ("svdckf", "ckf-eigh", {}),  # the SVD factor U·Σ draws the points eigh(P) gives
    ("srukf", "ukf", {}),
    ("srukf", "ukf", {"alpha": 0.5, "beta": 2.0, "kappa": 0.0}),  # negative centre weight
    ("srcdkf", "cdkf", {}),
]


@pytest.mark.parametrize(("sqrt_name", "dense_name", "params"), TWINS)
def test_square_root_equals_dense_twin_on_nonlinear_model(sqrt_name, dense_name, params):
    tr, me = nonlinear_models()
    zs = nonlinear_data(200, seed=3)
    s_f = make_filter(sqrt_name, **params)
    if dense_name == "ckf-eigh":
        d_f = SigmaPointFilter("ckf-eigh", Cubature(), "dense", sqrt_method="eigh")
    else:
        d_f = make_filter(dense_name, **params)
    if params:
        assert Unscented(**params).weights_c(3)[0] < 0.0  # the case the downdate exists for
    P0 = np.diag([0.5, 0.5, 0.3])
    s = s_f.init(np.array([0.5, 0.1, 1.0]), Euclidean(3), cov=P0)
    d = d_f.init(np.array([0.5, 0.1, 1.0]), Euclidean(3), cov=P0)
    for z in zs:
        s, s_inn = s_f.update(s_f.predict(s, tr), me, z)
        d, d_inn = d_f.update(d_f.predict(d, tr), me, z)
        np.testing.assert_allclose(s.mean, d.mean, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(s.cov, d.cov, rtol=1e-9, atol=1e-14)
        assert s_inn.nis == pytest.approx(d_inn.nis, rel=1e-9)
    if sqrt_name != "svdckf":
        np.testing.assert_array_equal(s.sqrt, np.tril(s.sqrt))
        assert np.all(np.diagonal(s.sqrt) > 0)


def test_dense_ukf_equals_filterpy():
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    alpha, beta, kappa = 0.8, 2.0, 0.5
    tr, me = nonlinear_models()
    zs = nonlinear_data(100, seed=4)
    x0, P0 = np.array([0.5, 0.1, 1.0]), np.diag([0.5, 0.5, 0.3])

    pts = MerweScaledSigmaPoints(3, alpha=alpha, beta=beta, kappa=kappa)
    fp = UnscentedKalmanFilter(dim_x=3, dim_z=2, dt=0.1, points=pts,
                               fx=lambda x, dt: tr.f(x[None, :], None)[0],
                               hx=lambda x: me.h(x[None, :])[0])
    fp.x, fp.P, fp.Q, fp.R = x0.copy(), P0.copy(), tr.noise.cov.copy(), me.noise.cov.copy()

    ukf = make_filter("ukf", alpha=alpha, beta=beta, kappa=kappa)
    b = ukf.init(x0, Euclidean(3), cov=P0)
    for z in zs:
        fp.predict()
        # filterpy's update reuses the propagated points; the additive-noise UKF here
        # redraws them from the predicted (x, P), so do the same to compare like with like
        fp.sigmas_f = fp.points_fn.sigma_points(fp.x, fp.P)
        fp.update(z)
        b, _ = ukf.update(ukf.predict(b, tr), me, z)
        np.testing.assert_allclose(b.mean, fp.x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.cov, fp.P, rtol=1e-9, atol=1e-14)


def test_square_root_survives_where_dense_loses_positive_definiteness():
    """Near-perfect measurements drive the covariance's condition number past 1e12.

    The dense CKF forms P - K Pzz Kᵀ and loses positive definiteness (its next
    Cholesky fails or P gets a negative eigenvalue); the SRCKF's QR-built factor
    stays lower triangular with a positive diagonal and reproduces a valid P.
    """
    n = 4
    tr = Transition(lambda X, u: X, Noise.from_cov(1e-16 * np.eye(n)))
    Hm = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 1.0, 1.0, 1e-3]])
    me = Measurement(lambda X: X @ Hm.T, Noise.from_cov(1e-14 * np.eye(2)))
    P0 = np.diag([1e4, 1e2, 1.0, 1e-2])
    dense, sq = make_filter("ckf"), make_filter("srckf")
    d = dense.init(np.zeros(n), Euclidean(n), cov=P0)
    s = sq.init(np.zeros(n), Euclidean(n), cov=P0)
    dense_failed = False
    for _ in range(30):
        s, _ = sq.update(sq.predict(s, tr), me, np.zeros(2))
        if not dense_failed:
            try:
                d, _ = dense.update(dense.predict(d, tr), me, np.zeros(2))
                dense_failed = np.linalg.eigvalsh(d.cov).min() <= 0.0
            except NotPositiveDefiniteError:
                dense_failed = True
    assert isinstance(s, SqrtGaussian)
    eig = np.linalg.eigvalsh(s.cov)
    assert eig.max() / eig.min() >= 1e12
    assert np.all(np.diagonal(s.sqrt) > 0.0)
    np.testing.assert_array_equal(s.sqrt, np.tril(s.sqrt))
    assert dense_failed


def test_filters_keep_no_state_and_do_not_mutate_inputs():
    tr, me = nonlinear_models()
    for name in FILTER_NAMES:
        f = make_filter(name)
        b0 = f.init(np.array([0.5, 0.1, 1.0]), Euclidean(3), cov=np.eye(3) * 0.1)
        before = (b0.mean.copy(), b0.cov.copy())
        z = np.array([1.2, 0.05])
        first = f.update(f.predict(b0, tr), me, z)[0]
        second = f.update(f.predict(b0, tr), me, z)[0]
        np.testing.assert_array_equal(first.mean, second.mean)
        np.testing.assert_array_equal(b0.mean, before[0])
        np.testing.assert_array_equal(b0.cov, before[1])


def test_unscented_rule_rejects_degenerate_spread():
    with pytest.raises(ValueError, match="n \\+ lambda"):
        Unscented(alpha=1.0, beta=2.0, kappa=-3.0).points(3)
