"""Tests of the GTSAM planar SLAM reference (slam/kinds/planar/reference.py)."""

from __future__ import annotations

import dataclasses

import gtsam
import numpy as np
import pytest
from scipy.stats import chi2

from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.odometry import (
    body_to_world_cov,
    epoch_steps_of,
    interpolate_reference,
    relative_motions,
    world_to_body_cov,
)
from slam.kinds.planar.reference import smooth_planar

DT = 0.025
WB = 4.0
Q = np.diag([0.3**2, np.deg2rad(3.0) ** 2])  # speed, steer
R = np.diag([0.1**2, np.deg2rad(1.0) ** 2])  # range, bearing
LANDMARKS = np.array([[5.0, 25.0], [-12.0, 10.0], [15.0, 5.0], [0.0, -10.0], [20.0, 20.0]])


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def _car(x0: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Bailey's car model, batched: x0 (..., 3), controls (..., K, 2) -> (..., K+1, 3)."""
    x0 = np.asarray(x0, dtype=float)
    K = controls.shape[-2]
    out = np.empty((*x0.shape[:-1], K + 1, 3))
    out[..., 0, :] = x0
    for k in range(K):
        V, G = controls[..., k, 0], controls[..., k, 1]
        x, y, p = out[..., k, 0], out[..., k, 1], out[..., k, 2]
        out[..., k + 1, 0] = x + V * DT * np.cos(G + p)
        out[..., k + 1, 1] = y + V * DT * np.sin(G + p)
        out[..., k + 1, 2] = _wrap(p + V * DT * np.sin(G) / WB)
    return out


def _circle_log(
    seed: int, *, K: int = 400, noise: bool = True, P0: np.ndarray | None = None
) -> PlanarLog:
    """Constant (V, G) circle of ~12 m radius, 5 landmarks, observations every 8 steps."""
    rng = np.random.default_rng(seed)
    x0 = np.array([0.0, 0.0, 0.3])
    P0 = np.zeros((3, 3)) if P0 is None else P0
    x_true0 = x0 + rng.multivariate_normal(np.zeros(3), P0) if (noise and P0.any()) else x0
    u = np.tile([3.0, np.deg2rad(20.0)], (K, 1))
    truth = _car(x_true0, u)
    controls = u + rng.multivariate_normal(np.zeros(2), Q, K) if noise else u.copy()
    steps, ids, obs = [], [], []
    for k in range(8, K + 1, 8):
        for j, lm in enumerate(LANDMARKS):
            d = lm - truth[k, :2]
            r = float(np.hypot(*d))
            if r < 30.0:
                z = np.array([r, np.arctan2(d[1], d[0]) - truth[k, 2]])
                if noise:
                    z += rng.multivariate_normal(np.zeros(2), R)
                z[1] = _wrap(z[1])
                steps.append(k)
                ids.append(j)
                obs.append(z)
    return PlanarLog(
        dt=DT,
        wheelbase=WB,
        x0=x0,
        P0=P0,
        controls=controls,
        control_cov=Q,
        obs_step=np.array(steps, dtype=np.int64),
        obs_id=np.array(ids, dtype=np.int64),
        obs=np.array(obs).reshape(-1, 2),
        obs_cov=R,
        truth=truth,
        landmarks=LANDMARKS,
    )


def test_noise_free_log_recovers_truth():
    log = _circle_log(0, noise=False)
    ref = smooth_planar(log)
    assert list(ref.epoch_steps) == list(range(0, log.n_steps + 1, 8))
    truth = log.truth[ref.epoch_steps]
    assert np.abs(ref.poses[:, :2] - truth[:, :2]).max() < 1e-6
    assert np.abs(_wrap(ref.poses[:, 2] - truth[:, 2])).max() < 1e-8
    assert list(ref.landmark_ids) == list(range(len(LANDMARKS)))
    assert np.abs(ref.landmarks - LANDMARKS).max() < 1e-6
    assert ref.objective < 1e-12
    path = interpolate_reference(ref, log)
    assert path.shape == (log.n_steps + 1, 3)
    assert np.abs(path[:, :2] - log.truth[:, :2]).max() < 1e-6
    assert np.abs(_wrap(path[:, 2] - log.truth[:, 2])).max() < 1e-8


def test_noisy_log_beats_dead_reckoning_and_fits_chi2():
    log = _circle_log(1)
    ref = smooth_planar(log)
    path = interpolate_reference(ref, log)
    np.testing.assert_allclose(path[ref.epoch_steps], ref.poses)
    dead = _car(log.x0, log.controls)

    def rmse(p):
        return np.sqrt(np.mean(np.sum((p[:, :2] - log.truth[:, :2]) ** 2, axis=1)))

    assert rmse(path) < 0.5 * rmse(dead)
    lm_err = np.linalg.norm(ref.landmarks - LANDMARKS[ref.landmark_ids], axis=1)
    assert np.sqrt(np.mean(lm_err**2)) < 0.1
    # the optimum's chi^2 matches its degrees of freedom (wrong noise models would not)
    n_res = 2 * len(log.obs) + 3 * len(ref.epoch_steps)
    dof = n_res - 3 * len(ref.epoch_steps) - 2 * len(ref.landmark_ids)
    lo, hi = chi2.ppf([0.001, 0.999], dof)
    assert lo < 2.0 * ref.objective < hi
    assert ref.objective <= ref.objective_isam2 + 1e-9
    assert ref.time_s >= ref.time_solve_s > 0.0


@pytest.mark.parametrize(
    "epochs",
    [
        np.array([0, 3, 11, 19]),  # an 8-step factor between two others: 11 -> 19
        np.array([0, 5, 85]),  # a long turn (0.75 rad): frame rotation and lever matter
    ],
)
def test_between_factor_covariance_matches_monte_carlo(epochs):
    rng = np.random.default_rng(7)
    K = int(epochs[-1])
    G = np.deg2rad(np.linspace(-25.0, 28.0, K)) if K < 50 else np.full(K, np.deg2rad(30.0))
    u = np.column_stack([3.0 + 0.2 * np.sin(np.arange(K)), G])
    rel, cov = relative_motions(u, Q, DT, WB, epochs)
    a, b = int(epochs[-2]), int(epochs[-1])
    seg = u[a:b]
    ident = _car(np.zeros(3), seg)[-1]  # compounded from the identity
    np.testing.assert_allclose(rel[-1, :2], ident[:2], atol=1e-12)
    assert abs(_wrap(rel[-1, 2] - ident[2])) < 1e-12

    n = 20000
    noisy = seg + rng.multivariate_normal(np.zeros(2), Q, (n, b - a))
    ends = _car(np.zeros((n, 3)), noisy)[:, -1]
    pred_inv = gtsam.Pose2(*rel[-1]).inverse()
    xi = np.array([gtsam.Pose2.Logmap(pred_inv.compose(gtsam.Pose2(*e))) for e in ends])
    mc = np.cov(xi.T)
    np.testing.assert_allclose(np.diag(cov[-1]), np.diag(mc), rtol=0.1)
    sd, mc_sd = np.sqrt(np.diag(cov[-1])), np.sqrt(np.diag(mc))
    np.testing.assert_allclose(cov[-1] / np.outer(sd, sd), mc / np.outer(mc_sd, mc_sd), atol=0.05)


def test_one_step_covariance_is_rank_two():
    u = np.array([[3.0, 0.2]])
    _, cov1 = relative_motions(u, Q, DT, WB, np.array([0, 1]))
    assert np.linalg.matrix_rank(cov1[0], tol=1e-12 * np.abs(cov1[0]).max()) == 2


def test_observations_every_step_give_finite_objective():
    # one-step odometry factors are singular without the lateral sigma
    log = _circle_log(2, K=40)
    k = np.arange(1, 41)
    d, th = LANDMARKS[0] - log.truth[k, :2], log.truth[k, 2]
    log = PlanarLog(
        dt=DT,
        wheelbase=WB,
        x0=log.x0,
        P0=log.P0,
        controls=log.controls,
        control_cov=Q,
        obs_step=k,
        obs_id=np.zeros(40, dtype=np.int64),
        obs=np.column_stack([np.hypot(d[:, 0], d[:, 1]), _wrap(np.arctan2(d[:, 1], d[:, 0]) - th)]),
        obs_cov=R,
        truth=log.truth,
    )
    assert len(epoch_steps_of(log)) == 41
    ref = smooth_planar(log)
    assert np.isfinite(ref.objective) and np.all(np.isfinite(ref.pose_cov))


def test_world_frame_covariance_conversion():
    body = np.diag([4.0, 1.0, 0.01])
    world = body_to_world_cov(np.pi / 2, body)
    np.testing.assert_allclose(world, np.diag([1.0, 4.0, 0.01]), atol=1e-12)
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 3, 3))
    covs = A @ np.swapaxes(A, 1, 2)
    th = rng.uniform(-np.pi, np.pi, 5)
    np.testing.assert_allclose(world_to_body_cov(th, body_to_world_cov(th, covs)), covs)

    # straight run due north, no observations: along-track (world y) variance is
    # K (sigma_V dt)^2 and cross-track (world x) variance the steering noise's lever sum,
    # both exact to first order; a fast, noisy speed makes them differ by 10x
    K, V = 100, 3.0
    Qn = np.diag([1.0**2, np.deg2rad(3.0) ** 2])
    log = PlanarLog(
        dt=DT,
        wheelbase=WB,
        x0=np.array([1.0, 2.0, np.pi / 2]),
        P0=np.zeros((3, 3)),
        controls=np.tile([V, 0.0], (K, 1)),
        control_cov=Qn,
        obs_step=np.zeros(0, dtype=np.int64),
        obs_id=np.zeros(0, dtype=np.int64),
        obs=np.zeros((0, 2)),
        obs_cov=R,
    )
    lateral = 2e-3
    ref = smooth_planar(log, lateral_sigma_m=lateral)
    assert list(ref.epoch_steps) == [0, K]
    np.testing.assert_allclose(ref.poses[-1], [1.0, 2.0 + V * DT * K, np.pi / 2], atol=1e-9)
    P = ref.pose_cov[-1]
    along = K * (1.0 * DT) ** 2
    lever = V * DT * (K - 1 - np.arange(K))
    cross = np.sum((V * DT) ** 2 * Qn[1, 1] * (1.0 + lever / WB) ** 2) + lateral**2
    np.testing.assert_allclose(P[1, 1], along, rtol=1e-6)
    np.testing.assert_allclose(P[0, 0], cross, rtol=1e-6)
    assert P[0, 0] < 0.15 * P[1, 1]
    assert abs(P[0, 1]) < 1e-9 * P[1, 1]


def test_final_pose_nees_is_consistent():
    # anisotropic initial uncertainty with a non-zero heading exercises the prior's frame
    P0 = np.diag([0.3**2, 0.05**2, np.deg2rad(2.0) ** 2])
    nees = []
    for seed in range(100, 130):
        log = _circle_log(seed, K=240, P0=P0)
        ref = smooth_planar(log)
        e = ref.poses[-1] - log.truth[-1]
        e[2] = _wrap(e[2])
        nees.append(e @ np.linalg.solve(ref.pose_cov[-1], e))
    n = len(nees)
    lo, hi = chi2.ppf([0.025, 0.975], 3 * n) / n
    assert lo < np.mean(nees) < hi


def test_rejects_observation_after_last_step():
    log = _circle_log(0, K=16, noise=False)
    bad = dataclasses.replace(log, obs_step=log.obs_step + 8)
    with pytest.raises(ValueError):
        smooth_planar(bad)
