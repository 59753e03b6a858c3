"""The drone's invariant variants (:mod:`slam.kinds.drone.variants`): tracking a noise-free
log to round-off, the EKF's Jacobians in the group error against finite differences,
the process noise carried by the chain rule, the invariant EKF's estimate-independent
unobservable directions, and the names."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.linearise import numerical_jacobian
from nav.extended_pose_group import ExtendedPoseGroup
from nav.quaternion import qexp
from slam.kinds.drone import filtering
from slam.kinds.drone import models as dm
from slam.kinds.drone.filtering import run_drone_filter
from slam.kinds.drone.scoring import score
from slam.kinds.drone.simulate import simulate_drone
from slam.kinds.drone.variants import (
    VARIANT_NAMES,
    group_space,
    invariant_augmentation,
    invariant_imu_transition,
    invariant_observation,
    split_variant,
    unobservable_directions,
)
from slam.registry import get_kind
from tests.small_worlds import small_drone_world

HALF_LOOP = {"waypoints": [[30.0, 0.0], [30.0, 30.0]]}
TESTED = ("ekf-inv", "srckf-inv", "srukf-inv", "ckf-inv", "ukf-inv")
NAV = dm.NavFrame(0.01, np.array([0.0, 0.0, -9.80665]))          # no Earth rate
IMU = dm.ImuNoise(1e-4, 1e-3, 1e-6, 1e-5)


def _state(n_lm: int, rng: np.random.Generator) -> np.ndarray:
    return np.concatenate([rng.normal(size=3) * 5, rng.normal(size=3), qexp(rng.normal(size=3)),
                           rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-2,
                           rng.normal(size=3 * n_lm) * 10 + 20])


def _imu(rng: np.random.Generator, n: int = 20) -> tuple[np.ndarray, np.ndarray]:
    return rng.normal(size=(n, 3)) * 0.3, rng.normal(size=(n, 3)) + [0.0, 0.0, 9.8]


@pytest.fixture(scope="module")
def noise_free_log():
    w = small_drone_world(map={"bounds_m": [-20.0, 50.0, -20.0, 50.0],
                               "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0],
                                             [-6.0, 15.0]], **HALF_LOOP})
    return simulate_drone(w, np.random.default_rng(0), noise_scale=0.0)


@pytest.mark.parametrize("name", TESTED)
def test_noise_free_log_is_tracked_to_round_off(noise_free_log, name):
    """Exact IMU and sightings, assumed variances 1e-6 of nominal (the sigma-point
    filters' second-order terms then stay below 1e-8 m; 1e-12 is as exact but
    denormal-slow)."""
    log = noise_free_log
    est = run_drone_filter(log, name, noise_scale=1e-6)
    s = score(est, log)
    assert not est.diverged, est.failure
    assert np.nanmax(np.abs(s.err_pos)) < 1e-7
    assert np.nanmax(np.abs(s.err_att)) < 1e-9
    assert len(s.lm_err) == len(np.unique(log.obs_id)) >= 3 and np.max(s.lm_err) < 1e-7


def test_nearest_neighbour_association_runs_in_the_world_chart(monkeypatch):
    """Gated nearest neighbour on a noisy log: the invariant SRCKF's gates are given the
    belief in the drone's standard chart (the analytic H there), and it maps the same
    landmarks as with known ids and tracks as well (position RMSE within 10 %)."""
    w = small_drone_world(map={"bounds_m": [-20.0, 50.0, -20.0, 50.0],
                               "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0],
                                             [-6.0, 15.0]], **HALF_LOOP})
    log = simulate_drone(w, np.random.default_rng(3))

    def rmse(est) -> float:
        return float(np.sqrt(np.nanmean(np.sum(score(est, log).err_pos ** 2, axis=1))))

    seen, converted = [], []

    def spy(belief, *args):
        seen.append(belief)
        return nearest(belief, *args)

    def to_world(belief):
        out = world_belief(belief)
        converted.append(out)
        return out

    nearest, world_belief = filtering._nearest_neighbour, filtering.world_belief
    monkeypatch.setattr(filtering, "_nearest_neighbour", spy)
    monkeypatch.setattr(filtering, "world_belief", to_world)
    known = run_drone_filter(log, "srckf-inv")
    nn = run_drone_filter(log, "srckf-inv", association="nn")
    assert not nn.diverged, nn.failure
    assert len(nn.landmarks) == len(known.landmarks) == len(np.unique(log.obs_id))
    assert rmse(nn) < 1.1 * rmse(known)
    assert seen and all(any(b is c for c in converted) for b in seen)


def test_measurement_and_augmentation_jacobians_in_the_group_error():
    """H_ξ, F_ξ and G_ξ against central differences through the group space (exact
    models, so to difference accuracy)."""
    rng = np.random.default_rng(4)
    x = _state(3, rng)
    G3 = group_space(3)
    slots = np.array([2, 0])
    meas = invariant_observation(dm.observation_model(slots, np.eye(3)))
    J, _ = numerical_jacobian(lambda X, W: meas.h(X), x, G3, meas.space)
    assert np.allclose(meas.jacobian(x), J, atol=1e-6)
    z = dm.rae(x[None], slots)[0]
    aug = invariant_augmentation(dm.augmentation_model(3, z, np.eye(3) * 0.01))
    assert aug.space == group_space(5)
    Jn, _ = numerical_jacobian(lambda X, W: aug.f(X, z, W), x, G3, aug.space, nw=6)
    F, G = aug.jacobian(x, z)
    assert np.allclose(np.hstack([F, G]), Jn, atol=1e-6)


def test_transition_jacobian_and_noise_in_the_group_error():
    """F_ξ against central differences (Φ is the second-order discretisation of the error
    dynamics, so to 2e-3 as the standard Jacobian); M(y) Q_ξ M(y)ᵀ is the standard Q; the
    mean's own prediction is the model's."""
    rng = np.random.default_rng(7)
    x = _state(1, rng)
    gyro, acc = _imu(rng)
    model = invariant_imu_transition(x, 1, gyro, acc, NAV, IMU)
    std = dm.imu_transition(x, 1, gyro, acc, NAV, IMU)
    G1 = group_space(1)
    Jn, y = numerical_jacobian(lambda X, W: dm.propagate_points(X, gyro, acc, NAV), x, G1, G1)
    F = model.jacobian(x, (gyro, acc))
    assert np.max(np.abs(F - Jn)) < 2e-3 * np.max(np.abs(Jn))
    S = G1.to_world(y, model.noise.sqrt)
    assert np.allclose(S @ S.T, std.noise.cov, rtol=0, atol=1e-12 * np.abs(std.noise.cov).max())
    assert np.abs(model.noise.cov[dm.VEH_DIM:]).max() > 0.0      # attitude noise moves the map
    assert np.array_equal(model.f(x[None], (gyro, acc))[0], y)
    assert np.array_equal(model.f(x[None], (gyro.copy(), acc))[0], y)   # recomputed: same


def test_sigma_point_path_gets_the_end_point_from_its_own_propagation():
    """The sigma-point filters call ``f`` on their points first: the mean rides along as an
    extra row, ``f`` returns the points' propagation only, and the noise formed afterwards
    equals the one formed from the separately mechanised mean (the EKF's path)."""
    rng = np.random.default_rng(8)
    x = _state(2, rng)
    gyro, acc = _imu(rng)
    X = group_space(2).retract(x, rng.normal(size=(5, group_space(2).dim)) * 1e-2)
    sigma = invariant_imu_transition(x, 2, gyro, acc, NAV, IMU)
    Y = sigma.f(X, (gyro, acc))
    assert np.array_equal(Y, dm.propagate_points(X, gyro, acc, NAV))
    ekf = invariant_imu_transition(x, 2, gyro, acc, NAV, IMU)
    ekf.jacobian(x, (gyro, acc))
    assert np.allclose(sigma.noise.sqrt, ekf.noise.sqrt, rtol=0, atol=1e-15)
    assert sigma.noise.cov.shape == (sigma.noise.dim,) * 2 == (21, 21)


def _standard_directions(x: np.ndarray) -> np.ndarray:
    """The four unobservable directions in the standard error at ``x`` (they move with x)."""
    n = (len(x) - dm.VEH_AMBIENT) // 3
    return group_space(n).to_world(x, unobservable_directions(n))


def test_invariant_ekf_jacobians_keep_the_unobservable_directions_at_any_estimate():
    """Yaw about gravity and the three translations: with right-invariant error
    H_ξ(x) N = 0, F_ξ(x) N = N and the augmentation maps N to N at random, mutually
    inconsistent estimates x_a, x_b (the yaw column of F_ξ N to the discretisation accuracy
    of Φ, measured 2.6e-4 at Δt = 0.01 s and 1.6e-5 at 0.0025 s; the standard Jacobian
    at its own estimate is no better, 1.8e-4).  The standard EKF's H(x_b) N(x_a) and
    F(x_b) N(x_a) - N(y_b) are far from 0 (measured 45 for F)."""
    rng = np.random.default_rng(3)
    n = 3
    N = unobservable_directions(n)
    gyro, acc = _imu(rng)
    obs_std = dm.observation_model(np.arange(n), np.eye(3))
    obs = invariant_observation(obs_std)
    xa, xb = _state(n, rng), _state(n, rng)
    FN = []
    for x in (xa, xb):
        F = invariant_imu_transition(x, n, gyro, acc, NAV, IMU).jacobian(x, (gyro, acc))
        FN.append(F @ N)
        assert np.abs(F @ N - N)[:, 1:].max() < 1e-12          # translations: exact
        assert np.abs(F @ N - N).max() < 1e-3                  # yaw: O(Δt²) from Φ
        assert np.abs(obs.jacobian(x) @ N).max() < 1e-12
        z = np.array([12.0, 0.4, -0.2])
        aug = invariant_augmentation(dm.augmentation_model(n, z, np.eye(3) * 0.01))
        Fa, _ = aug.jacobian(x, z)
        assert np.allclose(Fa @ N, unobservable_directions(n + 1), atol=1e-12)
    assert np.abs(FN[0] - FN[1]).max() < 1e-3
    # the standard EKF: its Jacobians at x_b do not keep the directions of x_a
    assert np.abs(obs_std.jacobian(xb) @ _standard_directions(xa)).max() > 1e-2
    Fb = dm.imu_transition(xb, n, gyro, acc, NAV, IMU).jacobian(xb, (gyro, acc))
    yb = dm.propagate_points(xb[None], gyro, acc, NAV)[0]
    assert np.abs(Fb @ _standard_directions(xa) - _standard_directions(yb)).max() > 1.0


def test_names_reach_the_kind_and_world_files():
    assert split_variant("srckf-inv") == ("srckf", "inv")
    assert split_variant("svdckf-inv") == ("svdckf-inv", None)
    assert split_variant("srckf") == ("srckf", None)
    k = get_kind("drone-slam")
    assert set(VARIANT_NAMES) <= set(k.filters)
    local = set(k.mode_filters["local"])
    assert {"ekf-inv", "srckf-inv", "srukf-inv", "srcdkf-inv"} <= local
    assert not {"ckf-inv", "ukf-inv", "cdkf-inv"} & local
    w = small_drone_world(filters={"names": ["srckf-inv", "ekf"]})
    assert list(w.filters.names) == ["srckf-inv", "ekf"]
    w = small_drone_world(filters={"names": ["srckf-inv"], "mode": "local"})
    assert w.filters.mode == "local"
    with pytest.raises(ValueError, match="joint"):
        small_drone_world(filters={"names": ["ckf-inv"], "mode": "local"})


def test_names_without_a_local_mode_are_refused(noise_free_log):
    with pytest.raises(ValueError, match="has no local mode"):
        run_drone_filter(noise_free_log, "ckf-inv", mode="local")


@pytest.fixture(scope="module")
def noisy_log():
    w = small_drone_world(map={"bounds_m": [-20.0, 50.0, -20.0, 50.0],
                               "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0],
                                             [-6.0, 15.0]], **HALF_LOOP})
    return simulate_drone(w, np.random.default_rng(3))


def test_local_invariant_ekf_equals_joint_mode(noisy_log):
    """Local mode keeps the covariance in the standard chart and transports it after each
    correction: for the EKF that is the invariant EKF exactly."""
    a = run_drone_filter(noisy_log, "ekf-inv", mode="joint")
    b = run_drone_filter(noisy_log, "ekf-inv", mode="local")
    assert not a.diverged and not b.diverged
    assert np.abs(a.p - b.p).max() < 1e-9
    assert np.abs(a.landmarks - b.landmarks).max() < 1e-9
    assert np.abs(a.pose_cov - b.pose_cov).max() < 1e-9 * np.abs(a.pose_cov).max()
    std = run_drone_filter(noisy_log, "ekf", mode="local")   # the transport is not a no-op
    assert np.abs(std.p - b.p).max() > 1e-6


def test_local_invariant_srckf_near_joint_mode(noisy_log):
    """Sigma points drawn in the standard chart: equal to joint mode to first order."""
    a = run_drone_filter(noisy_log, "srckf-inv", mode="joint")
    b = run_drone_filter(noisy_log, "srckf-inv", mode="local")
    sd = np.sqrt(a.pose_cov[-1, 0, 0])
    assert np.abs(a.p - b.p).max() < 0.1 * sd
    assert np.abs(a.pose_cov - b.pose_cov).max() < 0.05 * np.abs(a.pose_cov).max()


def test_group_space_keeps_the_drone_layout():
    G = group_space(4)
    assert isinstance(G, ExtendedPoseGroup) and G.side == "right"
    S = dm.state_space(4)
    assert (G.ambient_dim, G.dim) == (S.ambient_dim, S.dim)
