"""The invariant and first-estimates variants of the planar SLAM filters
(:mod:`slam.kinds.planar.variants`): tracking to round-off, the invariant EKF's
estimate-independent unobservable directions, FEJ's Jacobians, reduction to the standard
filters when the heading is nearly known, and the names.

A linear-Gaussian reduction test does not apply: the group space rotates every landmark
with the heading, so no planar SLAM model is linear in it."""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.planar.models import augmentation_model, motion_model, observation_model
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import run_slam
from slam.kinds.planar.variants import (
    VARIANT_NAMES,
    FirstEstimates,
    invariant_augment,
    invariant_motion,
    invariant_observation,
    split_variant,
)
from slam.registry import get_kind
from tests.small_worlds import small_world

HALF_LOOP = [[30.0, 0.0], [30.0, 30.0]]
TESTED = ("ekf-inv", "ekf-linv", "ekf-fej", "srckf-inv", "srukf-inv", "srcdkf-inv",
          "srckf-linv")


@pytest.fixture(scope="module")
def noise_free_log():
    return simulate_planar(small_world(waypoints=HALF_LOOP), np.random.default_rng(0),
                           noise_scale=0.0)


@pytest.mark.parametrize("name", TESTED)
def test_noise_free_log_is_tracked_to_round_off(noise_free_log, name):
    """Exact controls and observations, assumed noise at 1e-6 of nominal (σ)."""
    log = noise_free_log
    r = run_slam(log, name, noise_scale=1e-12)
    assert not r.diverged, r.failure
    err = np.hypot(*(r.poses[:, :2] - log.truth[r.steps, :2]).T)
    assert err.max() < 1e-6
    lm_err = np.linalg.norm(r.landmarks - log.landmarks[r.landmark_ids], axis=1)
    assert len(r.landmark_ids) == len(np.unique(log.obs_id)) and lm_err.max() < 1e-6


def _unobservable(n: int) -> np.ndarray:
    """Right-invariant error: a rotation of everything about the origin and the two
    translations, at every estimate (columns)."""
    N = np.zeros((3 + 2 * n, 3))
    N[2, 0] = 1.0
    for j in range(n + 1):
        r = 0 if j == 0 else 1 + 2 * j
        N[r:r + 2, 1:] = np.eye(2)
    return N


def _std_unobservable(x: np.ndarray) -> np.ndarray:
    """The same directions in the standard error at ``x`` (they depend on ``x``)."""
    n = (len(x) - 3) // 2
    N = _unobservable(n)
    pts = np.concatenate([x[:2], x[3:]]).reshape(-1, 2)
    for j, p in enumerate(pts):
        r = 0 if j == 0 else 1 + 2 * j
        N[r:r + 2, 0] = [-p[1], p[0]]
    return N


def test_invariant_ekf_jacobians_keep_the_unobservable_directions_at_any_estimate():
    """H_ξ N = 0 and F_ξ N = N (and the augmentation maps N to N) for random, mutually
    inconsistent estimates; the standard EKF's H(x_b) N(x_a) is far from 0 (the test can
    fail)."""
    rng = np.random.default_rng(3)
    n, dt, wb = 3, 0.025, 4.0
    ctrl = np.tile([3.0, 0.2], (8, 1))
    mot = invariant_motion(motion_model(dt, wb, np.diag([0.09, 0.003]), 8), "right")
    obs = invariant_observation(observation_model(np.arange(n), np.diag([0.01, 3e-4])), "right")
    N = _unobservable(n)
    for _ in range(5):
        x = rng.normal(size=3 + 2 * n) * 30.0
        x[2] = rng.uniform(-np.pi, np.pi)
        F, _ = mot.jacobian(x, ctrl)
        assert np.allclose(F @ N, N, atol=1e-9)
        assert np.abs(obs.jacobian(x) @ N).max() < 1e-12
        z = np.array([12.0, 0.4])
        aug = invariant_augment(augmentation_model(n, z, np.diag([0.01, 3e-4])), "right")
        Fa, _ = aug.jacobian(x, z)
        assert np.allclose(Fa @ N, _unobservable(n + 1), atol=1e-9)
    std = observation_model(np.arange(n), np.diag([0.01, 3e-4]))
    xa = rng.normal(size=3 + 2 * n) * 30.0
    xb = xa + rng.normal(size=3 + 2 * n)
    assert np.abs(std.jacobian(xb) @ _std_unobservable(xa)).max() > 1e-2


def test_fej_motion_jacobian_moves_the_first_estimates_null_space():
    """Huang et al. 2008: F_fej N(p̂_{k|k-1}) = N(p̂_{k+1|k}) exactly, with N the standard
    unobservable directions at the first estimates, although the EKF's current estimate
    (the updated pose) differs from the first one; the plain Jacobian at the current
    estimate breaks it."""
    dt, wb = 0.025, 4.0
    ctrl = np.tile([3.0, 0.3], (8, 1))
    base = motion_model(dt, wb, np.diag([0.09, 0.003]), 8)
    x_first = np.array([5.0, -2.0, 0.3, 10.0, 4.0])
    fe = FirstEstimates(x_first)
    x_now = x_first + np.array([0.4, -0.3, 0.05, 0.0, 0.0])     # after an update
    m = fe.motion(base, x_now, ctrl)
    F, _ = m.jacobian(x_now, ctrl)
    start = _std_unobservable(x_first)
    end_x = x_now.copy()
    end_x[:3] = fe.pose
    assert np.allclose(F @ start, _std_unobservable(end_x), atol=1e-12)
    F_std, _ = base.jacobian(x_now, ctrl)
    assert np.abs(F_std @ start - _std_unobservable(end_x)).max() > 1e-2


def _nearly_known_heading_log():
    world = small_world(waypoints=HALF_LOOP, noise={"sigma_steer_deg": 1e-4,
                                                   "sigma_speed_mps": 1e-3},
                        sensor={"sigma_bearing_deg": 1e-4})
    return simulate_planar(world, np.random.default_rng(5))


@pytest.mark.parametrize("base", ["ekf", "srckf"])
def test_invariant_filters_reduce_to_the_standard_ones_when_heading_is_nearly_known(base):
    """Steering σ 1e-4°, bearing σ 1e-4°, speed σ 1 mm/s: heading σ ≤ 1.1e-5 rad, position
    σ ≤ 5e-4 m.  Tolerance: the right-invariant filter's poses and landmarks equal the
    standard filter's within 1 % of the largest position σ of the run (5e-6 m), and its
    world-frame pose covariance within 1 % of the largest entry: the two errors differ by
    terms in the heading error, which is nearly zero here.  (Measured: 1.2-1.3e-6 m; with
    all noise 100× larger the difference grows to 7-8e-5 m, still ~0.3 % of the σ.)"""
    log = _nearly_known_heading_log()
    std, inv = run_slam(log, base), run_slam(log, f"{base}-inv")
    assert not std.diverged and not inv.diverged
    sd = float(np.sqrt(np.max(std.pose_cov[:, [0, 1], [0, 1]])))
    assert sd < 1e-3 and float(np.sqrt(np.max(std.pose_cov[:, 2, 2]))) < 2e-5
    assert np.abs(std.poses[:, :2] - inv.poses[:, :2]).max() < 1e-2 * sd
    assert np.abs(std.landmarks - inv.landmarks).max() < 1e-2 * sd
    assert np.abs(std.pose_cov - inv.pose_cov).max() < 1e-2 * np.abs(std.pose_cov).max()


def test_names_split_and_reach_the_kinds():
    assert split_variant("srckf-inv") == ("srckf", "inv")
    assert split_variant("ekf-fej") == ("ekf", "fej")
    assert split_variant("srckf-fej") == ("srckf-fej", None)
    assert split_variant("srckf") == ("srckf", None)
    for kind in ("planar-slam", "recorded-log"):
        k = get_kind(kind)
        assert set(VARIANT_NAMES) <= set(k.filters)
        local = set(k.mode_filters["local"])
        assert {"ekf-inv", "srckf-inv", "srukf-linv", "srcdkf-inv"} <= local
        assert not {"ekf-fej", "ckf-inv", "ukf-linv"} & local


@pytest.mark.parametrize("name", ["ekf-inv", "ekf-linv"])
def test_local_invariant_ekf_equals_joint_mode(name):
    """Local mode keeps the covariance in the world chart and transports it after every
    correction; for the EKF that is the invariant EKF exactly (noisy log, 4 landmarks)."""
    log = simulate_planar(small_world(), np.random.default_rng(3))
    a, b = run_slam(log, name, mode="joint"), run_slam(log, name, mode="local")
    assert not a.diverged and not b.diverged
    assert np.abs(a.poses - b.poses).max() < 1e-10
    assert np.abs(a.landmarks - b.landmarks).max() < 1e-10
    assert np.abs(a.pose_cov - b.pose_cov).max() < 1e-10 * np.abs(a.pose_cov).max()
    assert np.abs(a.nis - b.nis).max() < 1e-9
    std = run_slam(log, "ekf", mode="local")   # and the transport is not a no-op
    assert np.abs(std.poses - b.poses).max() > 1e-6


@pytest.mark.parametrize("name", ["srckf-inv", "srukf-linv", "srcdkf-inv"])
def test_local_invariant_sigma_point_filters_near_joint_mode(name):
    """The sigma-point filters draw their points in the world chart in local mode: equal to
    joint mode to first order (measured 1.5-2.3 mm against a pose σ of 8 cm)."""
    log = simulate_planar(small_world(), np.random.default_rng(3))
    a, b = run_slam(log, name, mode="joint"), run_slam(log, name, mode="local")
    sd = np.sqrt(a.pose_cov[-1, 0, 0])
    assert np.abs(a.poses[:, :2] - b.poses[:, :2]).max() < 0.1 * sd
    assert np.abs(a.landmarks - b.landmarks).max() < 0.1 * sd
    assert np.abs(a.pose_cov - b.pose_cov).max() < 0.02 * np.abs(a.pose_cov).max()


@pytest.mark.parametrize("name", ["ekf-inv", "srckf-inv", "srukf-linv"])
def test_local_mode_tracks_a_noise_free_log(noise_free_log, name):
    log = noise_free_log
    r = run_slam(log, name, noise_scale=1e-12, mode="local")
    assert not r.diverged, r.failure
    assert np.hypot(*(r.poses[:, :2] - log.truth[r.steps, :2]).T).max() < 1e-6
    assert np.linalg.norm(r.landmarks - log.landmarks[r.landmark_ids], axis=1).max() < 1e-6


def test_names_without_a_local_mode_are_refused(noise_free_log):
    for name in ("ekf-fej", "ukf-inv"):
        with pytest.raises(ValueError, match="has no local mode"):
            run_slam(noise_free_log, name, mode="local")
    with pytest.raises(ValueError, match="joint"):
        small_world(filters=("ekf-fej",), filter_options={"mode": "local"})


def test_world_file_accepts_variant_names():
    w = small_world(filters=("srckf-inv", "ekf-fej", "srukf-linv"))
    assert w.filters.names == ("srckf-inv", "ekf-fej", "srukf-linv") or \
        list(w.filters.names) == ["srckf-inv", "ekf-fej", "srukf-linv"]


def test_recorded_logs_run_the_variants():
    """The recorded-log kind (robot-frame point sightings, Pose2 odometry) runs the variants:
    on a simulated recorded log with truth they track the circuit as the standard EKF does
    (final landmark error within 1.5× the EKF's + 5 cm), in local mode too except FEJ."""
    from slam.kinds.recorded.models import run_recorded
    from tests.slam.kinds.recorded.test_run import _simulated_truth_log

    log, poses, lms = _simulated_truth_log(np.random.default_rng(4))

    def lm_rmse(r) -> float:
        ids = np.asarray(r.landmark_ids) - 1000
        return float(np.sqrt(np.mean(np.sum((r.landmarks - lms[ids]) ** 2, axis=1))))

    ref = lm_rmse(run_recorded(log, "ekf", mode="joint"))
    for name in ("ekf-inv", "ekf-fej", "srckf-inv"):
        r = run_recorded(log, name, mode="joint")
        assert not r.diverged, r.failure
        assert lm_rmse(r) < 1.5 * ref + 0.05, name
    r = run_recorded(log, "srckf-inv", mode="local")
    assert not r.diverged and lm_rmse(r) < 1.5 * ref + 0.05
    with pytest.raises(ValueError, match="has no local mode"):
        run_recorded(log, "ekf-fej", mode="local")
