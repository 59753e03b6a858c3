"""Filters on recorded logs (:mod:`slam.kinds.recorded.models`): a simulated log with known
truth, and the first 300 poses of Victoria Park against the GTSAM smoother.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.kinds.recorded.log import (
    OdometryLog,
    read_odometry_log,
)
from slam.kinds.recorded.models import (
    run_recorded,
)
from slam.kinds.recorded.reference import smooth_recorded
from slam.kinds.recorded.scoring import score_filter

FILTERS = ("ekf", "srckf", "srukf", "srcdkf")


def _simulated_truth_log(rng: np.random.Generator) -> tuple[OdometryLog, np.ndarray, np.ndarray]:
    """A circuit among 8 landmarks with odometry and sightings drawn from the models."""
    from slam.kinds.recorded.models import pose2_compose, pose2_exp

    K = 300
    lms = np.array([[np.cos(a) * 25, np.sin(a) * 25 + 20] for a in np.linspace(0, 6, 8)])
    true_d = np.tile([0.5, 0.0, 2 * math.pi / K], (K, 1))
    cov = np.diag([0.01, 0.002, 0.002]) ** 2
    L = np.linalg.cholesky(cov)
    poses = np.zeros((K + 1, 3))
    meas = np.empty((K, 3))
    for k in range(K):
        poses[k + 1] = pose2_compose(poses[k], true_d[k])
        w = rng.normal(size=3) @ L.T
        # T_{k+1} = T_k Δ Exp(w): the recorded Δ = true Δ Exp(-w)
        meas[k] = pose2_compose(true_d[k], pose2_exp(-w[None, :])[0])
    obs_pose, obs_id, obs = [], [], []
    for k in range(1, K + 1, 3):
        c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
        for j, m in enumerate(lms):
            d = m - poses[k, :2]
            z = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
            if np.hypot(*z) < 20 and z[0] > 0:
                obs_pose.append(k)
                obs_id.append(1000 + j)
                obs.append(z + rng.normal(0, 0.2, 2))
    M = len(obs_pose)
    log = OdometryLog(np.arange(K + 1), meas, np.tile(cov, (K, 1, 1)), np.array(obs_pose),
                      np.array(obs_id), np.array(obs), np.tile(np.eye(2) * 0.04, (M, 1, 1)))
    return log, poses, lms


def test_filters_track_a_simulated_recorded_log_consistently():
    log, poses, lms = _simulated_truth_log(np.random.default_rng(4))
    dr_end = 0.0
    for name in FILTERS:
        r = run_recorded(log, name, mode="local")
        assert not r.diverged, r.failure
        e = r.poses - poses[r.steps]
        e[:, 2] = (e[:, 2] + np.pi) % (2 * np.pi) - np.pi
        nees = np.einsum("ki,ki->k", e[1:], np.linalg.solve(r.pose_cov[1:], e[1:, :, None])[..., 0])
        assert 0.2 < nees.mean() / 3 < 3.0, (name, nees.mean() / 3)
        lm_err = np.linalg.norm(r.landmarks - lms[r.landmark_ids - 1000], axis=1)
        assert lm_err.max() < 1.0
    from slam.kinds.recorded.models import dead_reckoning_poses

    dr_end = np.hypot(*(dead_reckoning_poses(log)[-1, :2] - poses[-1, :2]))
    assert np.hypot(*(r.poses[-1, :2] - poses[-1, :2])) < dr_end


# --------------------------------------------------------------------------- the real log

@pytest.fixture(scope="module")
def victoria_prefix():
    import gtsam

    path = gtsam.findExampleDataFile("victoria_park.txt")
    full = read_odometry_log(path)
    assert full.n_poses == 6969 and len(full.landmark_ids) == 151 and len(full.obs) == 3640
    return full.prefix(300)


def test_victoria_park_prefix_filters_agree_with_smoother(victoria_prefix):
    """The first 300 poses (before the first large-innovation sightings of the real log):
    every filter in local mode ends within centimetres of the smoother."""
    log = victoria_prefix
    ref = smooth_recorded(log)
    assert ref.objective <= ref.objective_isam2 + 1e-6
    assert set(ref.landmark_ids) == set(log.landmark_ids)
    for name in FILTERS:
        r = run_recorded(log, name, mode="local")
        s = score_filter(r, ref)
        assert not s["diverged"], s
        assert s["landmarks_mapped"] == len(ref.landmark_ids)
        assert s["landmark_dist_to_ref_median_m"] < 0.05, s
        assert s["landmark_dist_to_ref_max_m"] < 0.2, s
        assert s["final_pose_dist_to_ref_m"] < 0.2, s
    joint = run_recorded(log, "ekf", mode="joint")
    local = run_recorded(log, "ekf", mode="local")
    np.testing.assert_allclose(local.landmarks, joint.landmarks, atol=1e-8)


def test_smoother_final_marginal_heading_is_the_summed_odometry_variance():
    """Odometry only: θ_K = θ_0 + Σ dθ, so the last pose's heading variance is the prior's
    plus every step's; sightings can only shrink it."""
    from slam.kinds.recorded.log import PRIOR_SIGMA

    log, _, _ = _simulated_truth_log(np.random.default_rng(4))
    K = 30
    chain = OdometryLog(np.arange(K + 1), log.odometry[:K], log.odometry_cov[:K],
                        np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64),
                        np.zeros((0, 2)), np.zeros((0, 2, 2)))
    ref = smooth_recorded(chain, final_marginal=True)
    expect = PRIOR_SIGMA**2 + log.odometry_cov[:K, 2, 2].sum()
    assert ref.final_pose_cov is not None
    assert ref.final_pose_cov[2, 2] == pytest.approx(expect, rel=1e-6)
    assert smooth_recorded(chain).final_pose_cov is None
    full = smooth_recorded(log, final_marginal=True)
    assert full.final_pose_cov[2, 2] < log.odometry_cov[:, 2, 2].sum()
