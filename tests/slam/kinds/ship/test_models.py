"""The ship's models (:mod:`slam.kinds.ship.models`, [Ding 2017] eq. 6-9, 15-16):

* the pseudo-observation of the true attitude equals the vector measurement's residual
  (to round-off), and the whitened stack equals the per-vector library models;
* its noise covariance passes a χ² test against Monte Carlo at the filters' initial prior
  (the library's uncorrected second moment does not);
* the process model is the strapdown attitude with the Earth rate;
* the additive quaternion mean; the HoMM rule the ``hommukf`` filter draws.

The HoMM rule's third and fourth moments for non-Gaussian inputs are tested in the core
(``tests/estimators/test_homm.py``); here only the ship's state dimension is checked.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from estimators.homm import HighOrderMoment
from nav.pseudo_observation import pseudo_observation_model, xi_matrix
from nav.quaternion import qexp, qmul, qnormalize, qrotate
from nav.quaternion_mean import eigen_mean
from nav.spaces import UnitQuaternion
from nav.strapdown import attitudes
from slam.kinds.ship.models import (
    AdditiveMeanQuaternion,
    earth_rate_transition,
    pseudo_observations,
    vector_measurement,
)
from slam.kinds.ship.run import initial_belief
from slam.kinds.ship.simulate import ShipLog, simulate_ship
from slam.kinds.ship.world import ShipWorld
from tests.slam.kinds.ship.worlds import ship_world

RNG_SEED = 21


def _log(duration: float = 10.0) -> tuple[ShipWorld, ShipLog]:
    w = ship_world(duration)
    return w, simulate_ship(w, np.random.default_rng(RNG_SEED))


def test_pseudo_observation_of_the_true_attitude_is_the_vector_residual() -> None:
    _, log = _log()
    vec = vector_measurement(log)
    P = np.diag([0.02, 0.05, 0.2]) ** 2
    for j in (0, 5, 10):
        x = np.concatenate([log.update_truth_q[j], log.update_truth_bias[j]])[None]
        residual = (log.vectors[j].ravel() - vec.h(x)[0]).reshape(2, 3)  # B̄ - C(q)ᵀR
        m = pseudo_observations(log.vectors[j], log.refs, log.sigmas, x[0, :4], P)
        T = xi_matrix(x[0, :4]).T
        expected = np.concatenate([0.5 * T @ xi_matrix(x[0, :4]) @ r / s
                                   for r, s in zip(residual, log.sigmas)])
        np.testing.assert_allclose(m.h(x)[0], expected, rtol=0, atol=1e-13)
        exact = qrotate(np.array([1.0, -1.0, -1.0, -1.0]) * x[0, :4], log.refs)  # C(q)ᵀR
        zero = pseudo_observations(exact, log.refs, log.sigmas, x[0, :4], P).h(x)[0]
        assert np.abs(zero).max() < 1e-15 / log.sigmas.min() * 100  # whitened by 1/σ


def test_whitened_stack_equals_the_per_vector_models() -> None:
    _, log = _log()
    q_hat = qmul(log.update_truth_q[3], qexp([0.01, -0.02, 0.05]))
    P = np.diag([0.01, 0.03, 0.1]) ** 2
    m = pseudo_observations(log.vectors[3], log.refs, log.sigmas, q_hat, P)
    X = np.concatenate([qnormalize(q_hat + 0.01 * np.arange(4.0)), np.zeros(3)])[None]
    for k, (b, r, s) in enumerate(zip(log.vectors[3], log.refs, log.sigmas)):
        one = pseudo_observation_model(b, r, s, q_hat, P)
        rows = slice(3 * k, 3 * k + 3)
        np.testing.assert_allclose(m.h(X)[0, rows], one.h(X)[0] / s, rtol=1e-13, atol=1e-16)
        np.testing.assert_allclose(m.noise.cov[rows, rows], one.noise.cov / s**2, rtol=1e-12,
                                   atol=1e-16)
        # the whitened block in closed form (the prior quaternion's second moment)
        np.testing.assert_allclose(m.noise.cov[rows, rows], 0.25 * np.eye(3) - P / 16.0,
                                   rtol=1e-12, atol=1e-16)


def _whitened_noise(q_hat: np.ndarray, P: np.ndarray, n: int, rng) -> np.ndarray:
    """Samples of the stacked whitened pseudo-observation noise ``½ T Ξ(q) μ/σ`` (two
    vectors) for attitudes ``q`` drawn from the prior ``q̂ ⊗ Exp(N(0, P))``."""
    q = qmul(q_hat, qexp(rng.multivariate_normal(np.zeros(3), P, size=n)))
    TXi = np.einsum("ij,njk->nik", xi_matrix(q_hat).T, xi_matrix(q))
    return np.hstack([0.5 * np.einsum("nik,nk->ni", TXi, rng.standard_normal((n, 3)))
                      for _ in range(2)])


def test_pseudo_observation_noise_passes_a_chi_square_test() -> None:
    """At the filters' initial prior (2°, 4°, 15°): the mean of vᵀR⁻¹v over n draws lies in
    the two-sided 99.9 % band of χ²(6n)/n; taking the unit q̂ as the ambient mean (the
    library's model before it used the second moment) over-states R by tr P/16 per axis
    and falls below the band."""
    w, log = _log()
    x0, P0 = initial_belief(w, log)
    rng = np.random.default_rng(22)
    n = 40_000
    v = _whitened_noise(x0[:4], P0[:3, :3], n, rng)
    m = pseudo_observations(log.vectors[0], log.refs, log.sigmas, x0[:4], P0[:3, :3])
    lo, hi = chi2.ppf([0.0005, 0.9995], 6 * n) / n

    def mean_d2(R: np.ndarray) -> float:
        return float(np.mean(np.einsum("ni,ni->n", v, np.linalg.solve(R, v.T).T)))

    assert lo < mean_d2(m.noise.cov) < hi
    first_order = m.noise.cov + np.trace(P0[:3, :3]) / 16.0 * np.eye(6)
    assert mean_d2(first_order) < lo


def test_process_model_is_the_strapdown_attitude_with_the_earth_rate() -> None:
    w, log = _log()
    trans = earth_rate_transition(log.samples_per_update, log.dt, 1e-6, 1e-9, log.earth_rate)
    x = np.concatenate([log.truth_q[0], [1e-5, -2e-5, 3e-5]])
    block = log.gyro_block(0)
    got = trans.f(x[None], block)[0]
    want = attitudes(x[:4], block - x[4:], log.dt, log.earth_rate)[-1]
    assert np.linalg.norm(UnitQuaternion().local(got[:4], want)) < 1e-13
    np.testing.assert_array_equal(got[4:], x[4:])


def test_additive_mean_is_the_renormalised_sum() -> None:
    rng = np.random.default_rng(23)
    centre = qnormalize(rng.normal(size=4))
    d = 0.3 * rng.normal(size=(4, 3))
    sym = qmul(centre, qexp(np.vstack([d, -d])))
    sym[1] *= -1.0  # the sign of a point does not matter
    w = np.full(8, 1.0 / 8.0)
    mean = AdditiveMeanQuaternion().mean(sym, w)
    np.testing.assert_allclose(mean, centre, atol=1e-14)
    skew = qmul(centre, qexp(np.vstack([d, -0.5 * d])))
    a = AdditiveMeanQuaternion().mean(skew, w)
    e = eigen_mean(skew, w)
    gap = np.linalg.norm(UnitQuaternion().local(a, e))
    assert 1e-6 < gap < 0.3**3  # different means, O(σ³) apart


def test_hommukf_moment_sets_on_the_ship_state() -> None:
    """The bundled world's HoMM-UKF takes the predicted points' moments; its first draw
    (the Gaussian prior) is the stated Gaussian set."""
    rule = ship_world(10.0).filters.make("hommukf").rule
    assert rule == HighOrderMoment(0.0, 3.0, moments="predicted")
    xi, wts = rule.points(6)
    np.testing.assert_allclose(wts @ xi**2, 1.0, rtol=1e-14)
    np.testing.assert_allclose(wts @ xi**3, 0.0, atol=1e-14)
    np.testing.assert_allclose(wts @ xi**4, 3.0, rtol=1e-14)
    assert abs(wts[0] + 1.0) < 1e-14  # κ = 3 - n: a negative centre weight for the 6-d state
    skew, kurt = (0.8, -0.3, 0.0, 0.0, 1.2, 0.0), (4.0, 3.5, 3.0, 2.5, 6.0, 3.0)
    xi, wts = HighOrderMoment(skew, kurt).points(6)  # a non-Gaussian input, same dimension
    np.testing.assert_allclose(wts @ xi**3, skew, atol=1e-13)
    np.testing.assert_allclose(wts @ xi**4, kurt, rtol=1e-13)
