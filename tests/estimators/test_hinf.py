"""Sigma-point H∞ filters (estimators.hinf) against closed-form references.

* γ → ∞ (1e8): SR-CH∞KF equals the SRCKF, UT-H∞ the UKF, on a nonlinear model;
* linear-Gaussian model, finite γ: both equal a hand-written linear H∞ filter (information
  form, cross-checked against the papers' augmented form) and bound the Kalman covariance;
* the Riccati existence check raises exactly when λmax(P_KF) ≥ γ², and the "kalman"
  policy falls back to the Kalman update and flags it.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Cubature, Euclidean, Measurement, Noise, Transition, Unscented
from estimators.filters import FILTER_NAMES, ROBUST_FILTER_NAMES, make_filter
from estimators.hinf import HInfinityFilter, RiccatiConditionError, riccati_min_eigenvalue
from estimators.sigma import SigmaPointFilter
from tests.linear_model import B, F, H, Q, R, linear_models, simulate_linear

# --------------------------------------------------------------------------- nonlinear model
# [Spin SR-CH∞KF]: state [pitch α, yaw β] driven by gyro increments, axial magnetometer reading
INC, DEC = np.deg2rad(-48.17), np.deg2rad(2.32)


def mag_models(r: float = 1e-3):
    def f(X, u):
        return X + u

    def h(X):
        a, b = X[:, 0], X[:, 1]
        return (np.cos(INC) * np.cos(a) * np.cos(DEC - b) + np.sin(INC) * np.sin(a))[:, None]

    return (Transition(f, Noise.from_cov(np.diag([2e-5, 2e-5]))),
            Measurement(h, Noise.from_cov(np.array([[r]]))))


def mag_data(n_steps: int, seed: int):
    tr, me = mag_models()
    rng = np.random.default_rng(seed)
    x = np.array([np.pi / 4, 0.1])
    us, zs = [], []
    for k in range(n_steps):
        u = np.array([-0.015, 0.01 * np.cos(0.05 * k)])
        x = x + u + rng.multivariate_normal(np.zeros(2), tr.noise.cov)
        us.append(u)
        zs.append(me.h(x[None, :])[0] + rng.normal(0.0, np.sqrt(me.noise.cov[0, 0]), 1))
    return us, zs


TWINS = [
    (HInfinityFilter("srchinf", Cubature(), "sqrt", gamma=1e8), make_filter("srckf")),
    (HInfinityFilter("uthinf", Unscented(), "dense", gamma=1e8), make_filter("ukf")),
    (HInfinityFilter("svdchinf", Cubature(), "svd", gamma=1e8), make_filter("svdckf")),
]


@pytest.mark.parametrize(("hinf", "kf"), TWINS, ids=lambda f: f.name)
def test_large_gamma_equals_kalman_twin_on_nonlinear_model(hinf, kf):
    tr, me = mag_models()
    us, zs = mag_data(100, seed=5)
    P0 = np.diag([0.05, 0.05])
    a = hinf.init(np.array([0.6, 0.0]), Euclidean(2), cov=P0)
    b = kf.init(np.array([0.6, 0.0]), Euclidean(2), cov=P0)
    for u, z in zip(us, zs):
        a, ia = hinf.update(hinf.predict(a, tr, u), me, z)
        b, ib = kf.update(kf.predict(b, tr, u), me, z)
        assert not ia.hinf_fallback
        np.testing.assert_allclose(a.mean, b.mean, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(a.cov, b.cov, rtol=1e-8, atol=1e-14)
        assert ia.nis == pytest.approx(ib.nis, rel=1e-8)
    # and the chosen gamma is what makes them equal: a finite one does not
    c = HInfinityFilter("c", hinf.rule, hinf.form, gamma=2.0)
    x = c.init(np.array([0.6, 0.0]), Euclidean(2), cov=P0)
    y = kf.init(np.array([0.6, 0.0]), Euclidean(2), cov=P0)
    for u, z in zip(us[:20], zs[:20]):
        x, _ = c.update(c.predict(x, tr, u), me, z)
        y, _ = kf.update(kf.predict(y, tr, u), me, z)
    assert np.max(np.abs(x.cov - y.cov) / np.abs(y.cov)) > 1e-3


# --------------------------------------------------------------------------- linear model
GAMMA = 3.0


def linear_hinf_reference(x0, P0, us, zs, gamma):
    """A-posteriori linear H∞ filter (L = I), written out independently.

    Mean with the Kalman gain of the predicted P; bound in information form
    P⁺ = (P⁻¹ + HᵀR⁻¹H − γ⁻²I)⁻¹, checked against the augmented (Krein) form
    P − [PHᵀ P] Re⁻¹ [HP; P], Re = [[HPHᵀ + R, HP], [PHᵀ, P − γ²I]].
    gamma = inf gives the Kalman filter.
    """
    x, P, out = x0.copy(), P0.copy(), []
    g2 = 0.0 if np.isinf(gamma) else gamma**-2
    Ri = np.linalg.inv(R)
    for u, z in zip(us, zs):
        x = F @ x + B @ u
        P = F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x = x + K @ (z - H @ x)
        Pn = np.linalg.inv(np.linalg.inv(P) + H.T @ Ri @ H - g2 * np.eye(4))
        if g2 > 0:
            Re = np.block([[S, H @ P], [P @ H.T, P - gamma**2 * np.eye(4)]])
            A = np.hstack([P @ H.T, P])
            np.testing.assert_allclose(P - A @ np.linalg.solve(Re, A.T), Pn, rtol=1e-9,
                                       atol=1e-12)
        P = 0.5 * (Pn + Pn.T)
        out.append((x.copy(), P.copy()))
    return out


LINEAR_HINF = [
    HInfinityFilter("srchinf", Cubature(), "sqrt", GAMMA),
    HInfinityFilter("uthinf", Unscented(), "dense", GAMMA),
    HInfinityFilter("uthinf-scaled", Unscented(0.5, 2.0, 0.0), "dense", GAMMA),  # w0 < 0
    HInfinityFilter("svdchinf", Cubature(), "svd", GAMMA),
]


@pytest.mark.parametrize("filt", LINEAR_HINF, ids=lambda f: f.name)
def test_linear_model_equals_closed_form_hinf_and_bounds_kalman(filt):
    us, zs = simulate_linear(150, seed=7)
    x0, P0 = np.zeros(4), np.diag([1.0, 2.0, 0.5, 1.5])
    ref = linear_hinf_reference(x0, P0, us, zs, GAMMA)
    kf = linear_hinf_reference(x0, P0, us, zs, np.inf)
    tr, me = linear_models()
    b = filt.init(x0, Euclidean(4), cov=P0)
    gaps = []
    for (u, z), (xr, Pr), (_, Pk) in zip(zip(us, zs), ref, kf):
        b, inn = filt.update(filt.predict(b, tr, u), me, z)
        assert not inn.hinf_fallback
        np.testing.assert_allclose(b.mean, xr, rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(b.cov, Pr, rtol=1e-9, atol=1e-13)
        gap = np.linalg.eigvalsh(b.cov - Pk)
        assert gap.min() >= -1e-12  # P_H∞ − P_KF is positive semidefinite ...
        gaps.append(gap.max())
    assert min(gaps) > 1e-3  # ... and strictly larger at every step for this γ


# --------------------------------------------------------------------------- existence check
def _one_step(filt, P0):
    us, zs = simulate_linear(1, seed=11)
    tr, me = linear_models()
    b = filt.init(np.zeros(4), Euclidean(4), cov=P0)
    return filt.update(filt.predict(b, tr, us[0]), me, zs[0])


def _kalman_lambda_max(P0):
    """λmax of the linear Kalman posterior after one step from P0 (closed form)."""
    P = F @ P0 @ F.T + Q
    Pkf = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.inv(R) @ H)
    return np.linalg.eigvalsh(Pkf).max()


@pytest.mark.parametrize(("rule", "form"), [(Cubature(), "sqrt"), (Unscented(), "dense"),
                                            (Cubature(), "svd")])
def test_riccati_condition_fires_exactly_at_the_bound(rule, form):
    P0 = np.diag([1.0, 2.0, 0.5, 1.5])
    lam = _kalman_lambda_max(P0)
    # just inside the bound: passes; just outside: raises with the exact eigenvalue
    ok = HInfinityFilter("ok", rule, form, gamma=np.sqrt(lam) * (1 + 1e-6))
    _, inn = _one_step(ok, P0)
    assert not inn.hinf_fallback
    gamma = np.sqrt(lam) * (1 - 1e-6)
    bad = HInfinityFilter("bad", rule, form, gamma=gamma)
    with pytest.raises(RiccatiConditionError, match="gamma=") as info:
        _one_step(bad, P0)
    assert isinstance(info.value, ArithmeticError)
    assert info.value.gamma == gamma
    assert info.value.min_eigenvalue == pytest.approx(1 / lam - gamma**-2, rel=1e-6)
    assert info.value.min_eigenvalue < 0
    assert f"{info.value.min_eigenvalue:.6e}" in str(info.value)


@pytest.mark.parametrize(("rule", "form", "twin"), [(Cubature(), "sqrt", "srckf"),
                                                    (Unscented(), "dense", "ukf")])
def test_kalman_policy_falls_back_and_reports_it(rule, form, twin):
    P0 = np.diag([1.0, 2.0, 0.5, 1.5])  # λmax(P_KF) ≈ 1.97 > γ² = 1
    filt = HInfinityFilter("fb", rule, form, gamma=1.0, on_failure="kalman")
    b, inn = _one_step(filt, P0)
    k, kinn = _one_step(make_filter(twin), P0)
    assert inn.hinf_fallback is True
    assert kinn.hinf_fallback is False
    np.testing.assert_allclose(b.mean, k.mean, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b.cov, k.cov, rtol=1e-12, atol=1e-14)
    # the same filter with a satisfiable gamma does not fall back and inflates P
    ok = HInfinityFilter("fb", rule, form, gamma=3.0, on_failure="kalman")
    b2, inn2 = _one_step(ok, P0)
    assert inn2.hinf_fallback is False
    assert np.linalg.eigvalsh(b2.cov - k.cov).min() > 1e-4


def test_riccati_min_eigenvalue_forms_agree():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + 0.1 * np.eye(3)
    S = np.linalg.cholesky(P)
    want = 1.0 / np.linalg.eigvalsh(P).max() - 1.0 / 4.0
    assert riccati_min_eigenvalue("dense", P, 2.0) == pytest.approx(want, rel=1e-12)
    assert riccati_min_eigenvalue("sqrt", S, 2.0) == pytest.approx(want, rel=1e-10)


def test_registry_and_validation():
    for name in ROBUST_FILTER_NAMES:
        f = make_filter(name, gamma=7.0, on_failure="kalman")
        assert isinstance(f, HInfinityFilter)
        assert (f.name, f.gamma, f.on_failure) == (name, 7.0, "kalman")
        assert name not in FILTER_NAMES
    assert make_filter("srchinf").form == "sqrt" and isinstance(make_filter("srchinf").rule,
                                                                 Cubature)
    assert make_filter("uthinf").form == "dense" and isinstance(make_filter("uthinf").rule,
                                                                Unscented)
    assert isinstance(make_filter("srchinf").kalman, SigmaPointFilter)
    with pytest.raises(ValueError, match="gamma"):
        HInfinityFilter("x", Cubature(), "sqrt", gamma=0.0)
    with pytest.raises(ValueError, match="on_failure"):
        HInfinityFilter("x", Cubature(), "sqrt", on_failure="ignore")  # type: ignore[arg-type]
