"""Joint vehicle-map SLAM on small worlds: plumbing, association, failure reporting."""

from __future__ import annotations

import numpy as np
import pytest
from small_worlds import small_world

from slam.kinds.planar.simulate import simulate_planar
from slam.mapping.joint import dead_reckoning, epochs_of, run_slam

SLAM_FILTERS = ("ekf", "srckf", "srukf", "srcdkf")


@pytest.fixture(scope="module")
def noise_free_log():
    return simulate_planar(small_world(), np.random.default_rng(0), noise_scale=0.0)


@pytest.mark.parametrize("name", SLAM_FILTERS)
def test_noise_free_log_is_tracked_exactly(noise_free_log, name):
    """Exact controls and observations, assumed noise sigmas at 1e-6 of nominal."""
    log = noise_free_log
    r = run_slam(log, name, noise_scale=1e-12)
    assert not r.diverged, r.failure
    truth = log.truth[r.steps]
    err = np.hypot(*(r.poses[:, :2] - truth[:, :2]).T)
    assert err.max() < 1e-6
    lm_err = np.linalg.norm(r.landmarks - log.landmarks[r.landmark_ids], axis=1)
    assert len(r.landmark_ids) == 4 and lm_err.max() < 1e-6


@pytest.mark.parametrize("name", SLAM_FILTERS)
def test_slam_beats_dead_reckoning_and_is_consistent(name):
    world = small_world(vehicle={"loops": 2})
    errs, odo_errs, nees = [], [], []
    for seed in range(6):
        log = simulate_planar(world, np.random.default_rng(seed))
        r = run_slam(log, name)
        assert not r.diverged, r.failure
        e = r.poses - log.truth[r.steps]
        e[:, 2] = (e[:, 2] + np.pi) % (2 * np.pi) - np.pi
        errs.append(np.hypot(e[:, 0], e[:, 1]))
        odo, _ = dead_reckoning(log, r.steps)
        odo_errs.append(np.hypot(*(odo[:, :2] - log.truth[r.steps, :2]).T))
        tail = slice(len(e) // 2, None)
        nees.append(np.einsum("ki,ki->k", e[tail],
                              np.linalg.solve(r.pose_cov[tail], e[tail][..., None])[..., 0]))
        assert np.all(r.nis_dof % 2 == 0) and 0.3 < np.mean(r.nis / r.nis_dof) < 3.0
    assert np.sqrt(np.mean(np.concatenate(errs) ** 2)) < 0.5 * np.sqrt(
        np.mean(np.concatenate(odo_errs) ** 2))
    # 6 runs: time-averaged NEES/3 well inside a loose band (a gross inconsistency fails)
    assert 0.3 < np.mean(np.concatenate(nees)) / 3.0 < 3.0


def test_known_and_nearest_neighbour_association_give_the_same_map():
    """On a world whose landmarks are >= 20 m apart, gated nearest neighbour finds the
    true ids.  With an accept gate of 20 (a correct 2-dof match exceeds it with
    probability e^-10) every observation is used, and the maps are identical."""
    world = small_world(vehicle={"loops": 2})
    log = simulate_planar(world, np.random.default_rng(3))
    known = run_slam(log, "srckf", association="known")
    nn = run_slam(log, "srckf", association="nn", gates=(20.0, 100.0))
    assert not known.diverged and not nn.diverged
    assert len(nn.landmarks) == len(known.landmarks) == 4
    np.testing.assert_array_equal(nn.nis_dof, known.nis_dof)
    np.testing.assert_allclose(nn.landmarks, known.landmarks, atol=1e-9)
    np.testing.assert_allclose(nn.poses, known.poses, atol=1e-9)


def test_bailey_gates_drop_some_true_matches_but_keep_the_map():
    """Bailey's accept gate 4.0 rejects a true 2-dof match with probability
    exp(-2) = 13.5 %: fewer updates, the same landmarks, a map within centimetres."""
    log = simulate_planar(small_world(vehicle={"loops": 2}), np.random.default_rng(3))
    known = run_slam(log, "srckf", association="known")
    nn = run_slam(log, "srckf", association="nn", gates=(4.0, 25.0))
    used = nn.nis_dof.sum() / known.nis_dof.sum()
    assert 0.78 < used < 0.95
    assert len(nn.landmarks) == 4
    assert np.linalg.norm(nn.landmarks - known.landmarks, axis=1).max() < 0.3


def test_epochs_cover_every_observation_and_the_scan_period(noise_free_log):
    log = noise_free_log
    steps = epochs_of(log, 8)
    assert steps[0] == 0 and steps[-1] == log.n_steps
    assert set(np.unique(log.obs_step)) <= set(steps)
    assert np.diff(steps).max() <= 8


def test_numerical_failure_is_reported_not_raised(noise_free_log):
    """The dense CKF must Cholesky-factor the known (zero) initial covariance to draw
    points; it cannot, and the run ends with ``diverged=True`` and the reason."""
    r = run_slam(noise_free_log, "ckf")
    assert r.diverged
    assert "NotPositiveDefinite" in r.failure
    assert np.isnan(r.poses[-1]).all()


def test_divergence_threshold_is_reported():
    log = simulate_planar(small_world(), np.random.default_rng(1))
    r = run_slam(log, "ekf", diverge_m=0.05)
    assert r.diverged and "vehicle error above 0.05 m" in r.failure
    assert np.isfinite(r.poses[0]).all() and np.isnan(r.poses[-1]).all()


def test_gated_choice_accepts_best_normalised_distance_new_or_ambiguous():
    from slam.mapping.association import NEW, gated_choice

    S = np.stack([np.eye(2), 4.0 * np.eye(2), np.eye(2)])
    # two candidates inside the gate: NIS 1.0 (det 1) vs NIS 0.5 (det 16): the normalised
    # distance nis + ln det picks the first, though its NIS is larger
    nu = np.array([[1.0, 0.0], [np.sqrt(2.0), 0.0], [10.0, 0.0]])
    assert gated_choice(nu, S, (4.0, 25.0)) == 0
    assert gated_choice(np.full((3, 2), 10.0), S, (4.0, 25.0)) == NEW  # all NIS > 25
    assert gated_choice(np.array([[2.5, 0.0], [6.0, 0.0], [9.0, 0.0]]), S,
                        (4.0, 25.0)) is None  # 6.25, 9, 81: none accepted, one below 25
    assert gated_choice(np.zeros((0, 2)), np.zeros((0, 2, 2)), (4.0, 25.0)) == NEW
