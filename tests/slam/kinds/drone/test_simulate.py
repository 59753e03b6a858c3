"""The drone simulation (:mod:`slam.kinds.drone.run`): truth over the terrain, noise-free
logs reproduced by mechanisation and tracked by every filter, terrain occlusion.
"""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.drone.filtering import imu_only, run_drone_filter
from slam.kinds.drone.scoring import score
from slam.kinds.drone.simulate import simulate_drone
from slam.kinds.drone.truth import terrain_of, truth_of
from slam.registry import world_from_dict
from tests.small_worlds import DRONE_FILTERS, small_drone_doc, small_drone_world

FILTERS = DRONE_FILTERS


def test_truth_keeps_height_and_landmarks_sit_on_the_terrain():
    w = small_drone_world()
    traj, lms = truth_of(w)
    ter = terrain_of(w)
    assert np.allclose(lms[:, 2], ter.height(lms[:, :2]))
    agl = traj.p[:, 2] - ter.height(traj.p[:, :2])
    assert abs(np.median(agl) - w.vehicle.height_above_ground_m) < 0.3


def test_noise_free_log_is_reproduced_by_pure_mechanisation():
    w = small_drone_world()
    log = simulate_drone(w, np.random.default_rng(0), noise_scale=0.0)
    s = score(imu_only(log), log)
    assert np.nanmax(np.abs(s.err_pos)) < 1e-9 and np.nanmax(np.abs(s.err_att)) < 1e-12


@pytest.mark.parametrize("name", FILTERS)
def test_filters_track_a_noise_free_log_with_tiny_assumed_noise(name):
    w = small_drone_world()
    log = simulate_drone(w, np.random.default_rng(0), noise_scale=0.0)
    assert len(np.unique(log.obs_id)) == 4
    est = run_drone_filter(log, name, noise_scale=1e-12)
    s = score(est, log)
    assert not est.diverged, est.failure
    assert np.nanmax(np.abs(s.err_pos)) < 1e-6
    assert np.nanmax(np.abs(s.err_att)) < 1e-6
    assert len(s.lm_err) == 4 and np.max(s.lm_err) < 1e-6


def test_terrain_hides_landmarks_behind_a_hill():
    # a tall hill in the middle of the square hides the far side's landmarks
    doc = small_drone_doc(terrain={"hill_amplitude_m": 25.0, "hill_width_m": 5.0},
                          vehicle={"height_above_ground_m": 2.0})
    seen = {}
    for los in (True, False):
        doc["sensor"] = {"line_of_sight": los}
        w = world_from_dict(doc, name="hill")
        seen[los] = simulate_drone(w, np.random.default_rng(1), noise_scale=0.0)
    assert 0 < len(seen[True].obs) < len(seen[False].obs)
    # every kept sighting has a clear line of sight
    log = seen[True]
    ter = terrain_of(w)
    e = log.obs_epoch
    assert ter.line_of_sight(log.truth[e, :3], log.landmarks[log.obs_id], 0.1).all()
