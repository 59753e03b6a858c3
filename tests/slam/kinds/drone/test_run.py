"""Drone filter runs (:mod:`slam.kinds.drone.run`): divergence reported, not raised; nearest
neighbour association.
"""

from __future__ import annotations

import numpy as np

from slam.kinds.drone.filtering import run_drone_filter
from slam.kinds.drone.scoring import score
from slam.kinds.drone.simulate import simulate_drone
from tests.small_worlds import small_drone_world


def test_divergence_is_reported_not_raised():
    w = small_drone_world()
    log = simulate_drone(w, np.random.default_rng(2))
    est = run_drone_filter(log, "srckf", diverge_m=1e-3)
    assert est.diverged and "position error" in est.failure
    s = score(est, log)
    from slam.kinds.drone.scoring import summarize_scores

    out = summarize_scores([s])
    assert out["diverged_runs"] == 1 and out["runs_scored"] == 0 and "pos_rmse_m" not in out


def test_nearest_neighbour_association_runs():
    w = small_drone_world(filters={"names": ["srckf"], "association": "nn"})
    log = simulate_drone(w, np.random.default_rng(3))
    est = run_drone_filter(log, "srckf", association="nn")
    assert not est.diverged and len(est.landmark_ids) >= 4 and np.all(est.landmark_ids == -1)
    s = score(est, log)
    assert np.nanmax(np.linalg.norm(s.err_pos, axis=1)) < 3.0
