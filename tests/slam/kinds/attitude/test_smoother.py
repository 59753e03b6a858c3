"""The star-sensor GTSAM smoother (:mod:`slam.kinds.attitude.run`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import slam.kinds.attitude.run as att
from nav.spaces import UnitQuaternion
from slam.chain_marginals import jacobian_rows
from slam.kinds.attitude.simulate import simulate_attitude
from tests.small_worlds import short_star_sensor_world

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]

def test_smoother_recovers_a_constant_drift() -> None:
    drift = np.array([20.0, -10.0, 15.0])  # deg/h; angle random walk limits it to ~0.2 deg/h
    w = short_star_sensor_world(300.0, **{"gyro.bias_deg_h": drift.tolist(),
                                          "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                                          "filters.initial_bias_var_deg_h2": 1e4})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(11))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    s = att.smooth_attitude(log, x0, P0, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s,
                            fs.star_sigma_rad, marginals=False)
    bias = s.means[:, 4:] / DEG_H
    assert np.abs(bias - drift).max() < 0.03 * np.linalg.norm(drift)
    err = UnitQuaternion().local(s.means[:, :4], log.star_truth_q)
    assert np.sqrt(np.mean(err**2)) < 10 * ARCSEC


def _scaled(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| / sqrt(a_ii a_kk): covariance differences relative to the std's."""
    d = np.sqrt(np.einsum("...ii->...i", a))
    return float(np.max(np.abs(a - b) / (d[..., :, None] * d[..., None, :])))


def _world_and_args(mode: str):
    w = short_star_sensor_world(60.0, **{"star_sensor.mode": mode})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(3))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    return log, (log, x0, P0, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s, fs.star_sigma_rad)


@pytest.mark.parametrize("mode", ["quaternion", "vectors"])
def test_chain_marginals_equal_the_dense_square_root_inverse(mode):
    """The chain recursion against R^-1 R^-T of one dense QR of the whole Jacobian."""
    import gtsam

    from slam.kinds.attitude import smoother as sm

    log, args = _world_and_args(mode)
    graph, values, X, B = sm.attitude_graph(*args)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    slots = {**{x: (j, 0) for j, x in enumerate(X)}, **{b: (j, 3) for j, b in enumerate(B)}}
    rows, _, base = jacobian_rows(graph, result, slots, 6, 0)
    M = log.n_star
    J = np.zeros((len(rows), 6 * M + 6))
    for i, (row, b) in enumerate(zip(rows, base)):
        J[i, 6 * b:6 * b + 12] = row
    R_inv = np.linalg.inv(np.linalg.qr(J[:, :6 * M], mode="r"))
    dense = np.stack([(R_inv[6 * j:6 * j + 6] @ R_inv[6 * j:6 * j + 6].T)
                      for j in range(M)])
    chain = sm.chain_covariances(graph, result, X, B)
    assert _scaled(dense, chain) < 1e-10  # measured: 8.6e-12 (quaternions), 9.2e-12
    reduction = sm.reduction_covariances(graph, result, X, B)
    assert _scaled(dense, reduction) < 1e-10  # measured: 1.8e-12 (quaternions), 1.2e-12


@pytest.mark.parametrize("mode", ["quaternion", "vectors"])
def test_chain_marginals_equal_gtsams_joint_marginals(mode):
    _, args = _world_and_args(mode)
    joint = att.smooth_attitude(*args, marginal_method="joint")
    chain = att.smooth_attitude(*args, marginal_method="chain")
    np.testing.assert_array_equal(chain.means, joint.means)
    # Measured 8.8e-9 (quaternions), 1.0e-8 (vectors): GTSAM's own error (its Bayes tree's
    # Cholesky; 7e-9 against a longdouble inverse on the 120 s world, the chain 6e-12).
    assert _scaled(joint.covs, chain.covs) < 5e-8
    with pytest.raises(ValueError, match="marginal_method"):
        att.smooth_attitude(*args, marginal_method="dense")


@pytest.mark.parametrize("mode", ["quaternion", "vectors"])
def test_the_fast_path_reaches_the_old_paths_optimum(mode):
    """Batched preintegration, the Wahba start, Gauss-Newton and the reduction's marginals
    against the old default (per-sample preintegration, dead-reckoned start, LM, GTSAM's
    joint marginals): ½χ² of each result on the old path's graph."""
    import gtsam

    from slam.kinds.attitude import smoother as sm

    log, args = _world_and_args(mode)
    old = att.smooth_attitude(*args, preintegration="samples", solver="lm",
                              marginal_method="joint", vector_start="dead-reckoning")
    new = att.smooth_attitude(*args)
    graph, values, X, B = sm.attitude_graph(*args, preintegration="samples",
                                            vector_start="dead-reckoning")

    def objective(s):
        v = gtsam.Values()
        for j, (x, b) in enumerate(zip(X, B)):
            v.insert(x, gtsam.Rot3.Quaternion(*s.means[j, :4]))
            v.insert(b, s.means[j, 4:])
        return graph.error(v)

    e_old, e_new = objective(old), objective(new)
    assert abs(e_new - e_old) <= 1e-9 * e_old  # measured 3.5e-15 (quaternions), 2.4e-14
    assert graph.error(values) > 10 * e_old  # the start is not the optimum
    assert _scaled(old.covs, new.covs) < 5e-8  # GTSAM's joint marginals' own error
    with pytest.raises(ValueError, match="solver"):
        att.smooth_attitude(*args, solver="dogleg")
    with pytest.raises(ValueError, match="preintegration"):
        att.smooth_attitude(*args, preintegration="exact")
    with pytest.raises(ValueError, match="vector_start"):
        att.smooth_attitude(*args, vector_start="triad")


def test_wahba_recovers_noiseless_attitudes() -> None:
    from nav.quaternion import qnormalize, qto_dcm
    from slam.kinds.attitude.smoother import wahba

    rng = np.random.default_rng(5)
    C = qto_dcm(qnormalize(rng.normal(size=(6, 4))))
    refs = rng.normal(size=(3, 3))
    refs /= np.linalg.norm(refs, axis=1, keepdims=True)
    body = np.einsum("mba,ib->mia", C, refs)  # b = Cᵀ r
    np.testing.assert_allclose(wahba(refs[:2], body[:, :2]), C, atol=1e-14)
    np.testing.assert_allclose(wahba(refs, body), C, atol=1e-14)


@pytest.mark.parametrize("mode", ["quaternion", "vectors"])
def test_gn_reduction_equals_gtsams_gauss_newton(mode):
    """The default solver (GTSAM's first Gauss-Newton step, the later ones by the
    reduction, the marginals from the last step's levels) against GTSAM's Gauss-Newton
    with the reduction's marginals at its result."""
    from slam.kinds.attitude import smoother as sm

    assert sm.SOLVER == "gn-reduction"
    _, args = _world_and_args(mode)
    gn = att.smooth_attitude(*args, solver="gauss-newton")
    new = att.smooth_attitude(*args)
    # Measured: means 1.1e-16 (quaternions), 2.8e-17 (vectors); the covariances 2.8e-9,
    # 8.0e-9 of sigma: linearised one Gauss-Newton step (which changed ½χ² by < 1e-6
    # relative) before the result - the size of the joint marginals' own error above.
    np.testing.assert_allclose(new.means, gn.means, rtol=0, atol=1e-12)
    assert _scaled(gn.covs, new.covs) < 5e-8
    assert sm._converged(10.0, 10.0 - 1e-6, 1e-6, 1e-9)  # relative decrease 1e-7
    assert sm._converged(10.0, 10.5, 1e-6, 1e-9)  # an increase stops
    assert not sm._converged(10.0, 9.0, 1e-6, 1e-9)
    assert sm._converged(0.0, 0.0, 1e-6, 1e-9)  # no division by a zero ½χ²
