"""The drone GTSAM smoother's schedules (:mod:`slam.kinds.drone.reference`): the keyframes
schedule reaches the epoch-by-epoch schedule's optimum of the same graph."""

from __future__ import annotations

import numpy as np
import pytest

import slam.kinds.drone.reference as ref
from slam.campaign import run_seeds
from slam.kinds.drone.simulate import simulate_drone
from tests.small_worlds import small_drone_world


@pytest.fixture(scope="module")
def log():
    return simulate_drone(small_drone_world(runs=1), np.random.default_rng(run_seeds(0, 1)[0]))


def _scaled(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| / sqrt(a_ii a_kk): covariance differences relative to the std's."""
    d = np.sqrt(np.einsum("...ii->...i", a))
    return float(np.max(np.abs(a - b) / (d[..., :, None] * d[..., None, :])))


def test_keyframes_reach_the_epochs_optimum_of_the_same_graph(log):
    ga, va, seen_a = ref.solve_graph(log, schedule="epochs", bias_point="prior")
    gb, vb, seen_b = ref.solve_graph(log, schedule="keyframes", bias_point="prior")
    assert seen_a == seen_b
    assert gb.error(va) == pytest.approx(ga.error(va), rel=1e-12)  # the same graph
    assert gb.error(vb) == pytest.approx(ga.error(va), rel=1e-9)  # measured: 1.1e-12


def test_keyframes_reach_the_optimum_with_a_large_initial_yaw_error():
    """drone-large-yaw run 0 (10 deg initial yaw sigma): fed ten keyframes per update, the
    keyframes' iSAM2 estimate led the final LM into a wrong minimum (73 m RMSE, 1/2 chi^2
    1.26e6 against 1643); one keyframe per update reaches the epochs schedule's optimum."""
    from slam.registry import load_world

    w = load_world("drone-large-yaw")
    log = simulate_drone(w, np.random.default_rng(run_seeds(w.seed, 1)[0]))
    ga, va, _ = ref.solve_graph(log, schedule="epochs", bias_point="prior")
    gb, vb, _ = ref.solve_graph(log, schedule="keyframes", bias_point="prior")
    assert gb.error(vb) == pytest.approx(ga.error(va), rel=1e-9)


@pytest.mark.parametrize("method, tol", [("chain", 1e-5), ("joint", 1e-5)])
def test_keyframes_marginals_equal_the_epochs_marginals(log, method, tol):
    a = ref.smooth_drone(log, schedule="epochs", bias_point="prior", marginal_method=method)
    b = ref.smooth_drone(log, schedule="keyframes", bias_point="prior", marginal_method=method)
    assert np.all(np.isfinite(b.pose_cov)) and np.all(np.isfinite(b.landmark_cov))
    # Measured: 2.7e-5 m (2.6e-8 m when fed ten keyframes per update). The two LM stops'
    # 1/2 chi^2 differ by 5.5e-11 relative, at this graph's numerical floor: one
    # Gauss-Newton (QR) step from either moves it by ~1e-8 (absolute), so the poses agree
    # to what the objective resolves along its flattest direction, not to round-off.
    np.testing.assert_allclose(b.p, a.p, rtol=0, atol=1e-4)
    # Measured (poses): chain 1.5e-6, joint 1.6e-6 of sigma - the marginals linearised at
    # the two LM stops above (2.7e-5 m apart). Fed ten keyframes per update the stops were
    # 2.6e-8 m apart and the marginals agreed to chain 1.4e-9, joint 2.2e-7 (GTSAM's
    # Marginals are off a dense QR inverse by ~1e-7 at this conditioning,
    # tests/slam/test_chain_marginals.py, the chain by ~1e-11).
    assert _scaled(a.pose_cov, b.pose_cov) < tol
    assert _scaled(a.landmark_cov, b.landmark_cov) < tol


def test_the_estimate_bias_point_makes_the_graph_depend_on_the_schedule(log, monkeypatch):
    """Why today's reference cannot be reproduced by a cheaper schedule: the intervals are
    preintegrated about iSAM2's bias estimate at each update."""
    today = {"schedule": "epochs", "bias_point": "estimate"}
    g5, v5, _ = ref.solve_graph(log, **today)
    monkeypatch.setattr(ref, "ISAM_BATCH", 25)
    g25, v25, _ = ref.solve_graph(log, **today)
    assert abs(g25.error(v25) - g5.error(v5)) > 1e-8 * g5.error(v5)  # measured: 2.7e-7


@pytest.mark.parametrize("schedule, bias_point", [("keyframes", "estimate"),
                                                  ("batch", "prior"), ("epochs", "zero")])
def test_unknown_schedules_and_bias_points_are_refused(log, schedule, bias_point):
    with pytest.raises(ValueError, match="schedule"):
        ref.solve_graph(log, schedule=schedule, bias_point=bias_point)


def test_default_chain_marginals_equal_gtsam_marginals_at_the_optimum(log):
    """The default marginals (the square-root chain) against GTSAM's ``Marginals`` on the
    same graph and values; and the bulk state read against the per-epoch one."""
    from gtsam.symbol_shorthand import B, V, X

    assert ref.MARGINAL_METHOD == "chain"
    graph, values, seen = ref.solve_graph(log)
    E = log.n_epochs
    st = ref.StateRows(E)
    for e in range(E):
        st.put(e, values.atPose3(X(e)), values.atVector(V(e)), values.atConstantBias(B(e)))
    for got, want in zip(ref._read_states(values, E), (st.p, st.v, st.bias, st.Rs)):
        np.testing.assert_array_equal(got, want)
    ids = np.array(sorted(seen))
    chain = ref._marginals(graph, values, st.Rs, ids, "chain")
    joint = ref._marginals(graph, values, st.Rs, ids, "joint")
    # Measured: poses 1.5e-7, landmarks 1.2e-7 of sigma (GTSAM's Bayes-tree Cholesky is
    # ~1e-7 off a dense QR inverse, the chain ~1e-11: tests/slam/test_chain_marginals.py).
    assert _scaled(joint[0], chain[0]) < 1e-6
    assert _scaled(joint[1], chain[1]) < 1e-6


def test_sightings_noise_equals_the_per_observation_noise(log):
    """The batched sightings' noise against :func:`ref.bearing_range_noise` per observation,
    and their factors' errors against the old per-epoch construction's."""
    import gtsam

    from slam.kinds.drone.sightings import sightings_factors

    factors, offsets = sightings_factors(log, log.obs_cov)
    assert len(factors) == len(log.obs)
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    pose = gtsam.Pose3(gtsam.Rot3.Ypr(0.3, -0.1, 0.2), np.array([1.0, -2.0, 0.5]))
    for e, sl in log.observations_at().items():
        ref._landmark_factors(log, e, sl, pose, log.obs_cov, set(), graph, gtsam.Values())
    worst = 0.0
    for i, (f, z) in enumerate(zip(factors, log.obs)):
        want = ref.bearing_range_noise(z, log.obs_cov).covariance()
        got = f.noiseModel().covariance()
        worst = max(worst, float(np.max(np.abs(got - want)) / np.max(np.abs(want))))
        keys = f.keys()
        assert list(keys) == list(graph.at(i).keys())
        if not values.exists(keys[0]):
            values.insert(keys[0], pose)
        if not values.exists(keys[1]):
            values.insert(keys[1], pose.transformFrom(offsets[i] * 1.01))
    assert worst < 1e-14  # measured: 0 (the same operations)
    for i, f in enumerate(factors):
        assert f.error(values) == pytest.approx(graph.at(i).error(values), rel=1e-12)


def test_the_keyframes_lm_tolerance_stops_at_the_same_optimum(log):
    """The keyframes schedule's LM stops at 1e-9 (relative decrease), one step before
    1e-10 would: the same optimum to well within the task's 1e-9 (½χ²)."""
    assert ref.LM_REL_TOL == {"epochs": 1e-10, "keyframes": 1e-9}
    g, a, _ = ref.solve_graph(log)
    _, b, _ = ref.solve_graph(log, lm_rel_tol=1e-10)
    assert g.error(a) == pytest.approx(g.error(b), rel=1e-11)  # measured 0 (same stop)
