"""The square-root chain marginals (:mod:`slam.chain_marginals`) against a dense QR of
the whole Jacobian, on the first epochs of a drone graph (a chain plus landmarks)."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import B, L, V, X

import slam.kinds.drone.reference as ref
from slam.campaign import run_seeds
from slam.chain_marginals import chain_marginals, jacobian_rows
from slam.kinds.drone.simulate import simulate_drone
from tests.small_worlds import small_drone_world

EPOCHS = 40


@pytest.fixture(scope="module")
def prefix():
    """The first ``EPOCHS`` epochs of the small drone log's graph at its optimum."""
    log = simulate_drone(small_drone_world(runs=1), np.random.default_rng(run_seeds(0, 1)[0]))
    params = ref.preintegration_params(log)
    graph, init = ref._prior_factors(log)
    obs_at, seen = log.observations_at(), set()
    pims = [ref._preintegrate(log, params, ref._bias(log.x0), e) for e in range(1, EPOCHS)]
    pose, vel, bias = init.atPose3(X(0)), init.atVector(V(0)), ref._bias(log.x0)
    for e in range(1, EPOCHS):
        graph.add(gtsam.CombinedImuFactor(X(e - 1), V(e - 1), X(e), V(e), B(e - 1), B(e),
                                          pims[e - 1]))
        pred = pims[e - 1].predict(gtsam.NavState(pose, vel), bias)
        pose, vel = pred.pose(), pred.velocity()
        init.insert(X(e), pose)
        init.insert(V(e), vel)
        init.insert(B(e), bias)
        sl = obs_at.get(e)
        if sl is not None:
            ref._landmark_factors(log, e, sl, pose, log.obs_cov, seen, graph, init)
    values = gtsam.LevenbergMarquardtOptimizer(graph, init).optimize()
    return graph, values, sorted(seen)


def _scaled(a: np.ndarray, b: np.ndarray) -> float:
    d = np.sqrt(np.einsum("...ii->...i", a))
    return float(np.max(np.abs(a - b) / (d[..., :, None] * d[..., None, :])))


def test_chain_marginals_equal_the_dense_square_root_inverse(prefix):
    graph, values, ids = prefix
    assert len(ids) >= 2
    n, g = 15, 3 * len(ids)
    slots = {X(e): (e, 0) for e in range(EPOCHS)}
    slots.update({V(e): (e, 6) for e in range(EPOCHS)})
    slots.update({B(e): (e, 9) for e in range(EPOCHS)})
    slots.update({L(j): (-1, 3 * i) for i, j in enumerate(ids)})
    local, glob, base = jacobian_rows(graph, values, slots, n, g)
    sig, cov_xl, s_ll = chain_marginals(local, glob, base, EPOCHS)
    J = np.zeros((len(local), n * (EPOCHS + 1) + g))
    for i, (row, b) in enumerate(zip(local, base)):
        J[i, n * b:n * b + 2 * n] = row
    J = np.hstack([J[:, :n * EPOCHS], glob])
    R_inv = np.linalg.inv(np.linalg.qr(J, mode="r"))
    full = R_inv @ R_inv.T
    dense = np.stack([full[n * j:n * j + n, n * j:n * j + n] for j in range(EPOCHS)])
    cross = np.stack([full[n * j:n * j + n, n * EPOCHS:] for j in range(EPOCHS)])
    # Measured 7.6e-12 (epochs), 1.7e-12 (landmarks); GTSAM's Marginals on the same graph:
    # 9.9e-8 off the dense inverse (its Bayes tree's Cholesky).
    assert _scaled(dense, sig) < 1e-9
    assert _scaled(full[n * EPOCHS:, n * EPOCHS:], s_ll) < 1e-9
    d_x = np.sqrt(np.einsum("jii->ji", dense))
    d_l = np.sqrt(np.diag(s_ll))
    assert np.max(np.abs(cross - cov_xl) / (d_x[:, :, None] * d_l[None, None, :])) < 1e-9


def test_a_row_across_non_consecutive_epochs_is_refused(prefix):
    graph, values, ids = prefix
    slots = {X(e): (2 * e, 0) for e in range(EPOCHS)}  # epochs spread apart
    slots.update({V(e): (2 * e, 6) for e in range(EPOCHS)})
    slots.update({B(e): (2 * e, 9) for e in range(EPOCHS)})
    slots.update({L(j): (-1, 3 * i) for i, j in enumerate(ids)})
    with pytest.raises(ValueError, match="consecutive"):
        jacobian_rows(graph, values, slots, 15, 3 * len(ids))
