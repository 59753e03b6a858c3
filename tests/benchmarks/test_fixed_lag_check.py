"""The relinearising window of benchmarks.fixed_lag_check (GTSAM's fixed-lag rows' foil)."""

from __future__ import annotations

import numpy as np

from benchmarks.fixed_lag_check import relinearised_window
from slam.kinds.planar.online import online_planar
from slam.kinds.planar.reference import graph_inputs
from slam.kinds.planar.simulate import simulate_planar
from tests.small_worlds import small_world


def test_the_window_marginalises_exactly_where_the_linearisation_is():
    """On a noise-free log every estimate sits at the truth, so the linear priors of the
    marginalised poses are exact: the window's pose and covariance are the full graph's (the
    online row's) at every epoch, for any lag - each covariance entry to 1e-8 of
    sqrt(P_ii P_jj) (measured worst 2.2e-10); a dropped or doubled prior would miss by O(1)."""
    log = simulate_planar(small_world(runs=1), np.random.default_rng(3), noise_scale=0.0)
    g = graph_inputs(log)
    full, _ = online_planar(log, g.steps)
    d = np.sqrt(np.diagonal(full.pose_cov, axis1=1, axis2=2))
    scale = d[:, :, None] * d[:, None, :]
    for lag in (0.0, 1.0):
        win = relinearised_window(log, g.steps, lag)
        np.testing.assert_allclose(win.poses, full.poses, rtol=0, atol=1e-9)
        worst = np.max(np.abs(win.pose_cov - full.pose_cov) / scale)
        assert worst < 1e-8, (lag, worst)
        np.testing.assert_array_equal(win.landmark_ids, full.landmark_ids)
