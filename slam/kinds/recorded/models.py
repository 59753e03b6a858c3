"""Filter models of a recorded log: Pose2 odometry, a robot-frame point measurement, its
augmentation, and the log as a :class:`~slam.mapping.problem.SlamProblem`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from estimators import Euclidean, Measurement, Noise, Transition, wrap_angle
from estimators.linalg import Array
from slam.kinds.planar.models import state_space
from slam.kinds.planar.slam import PlanarVariant
from slam.kinds.planar.variants import problem_for
from slam.kinds.recorded.log import DEFAULT_MAX_EPOCH_STEPS, OdometryLog
from slam.mapping.problem import SlamProblem, SlamResult, run_problem

# --------------------------------------------------------------------------- filter models


def pose2_exp(w: Array) -> Array:
    r"""``Pose2.Expmap`` of rows ``[v_x, v_y, ω]`` -> ``[x, y, θ]`` (vectorised)."""
    th = w[:, 2]
    small = np.abs(th) < 1e-5
    ts = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th**2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, th / 2.0 - th**3 / 24.0, (1.0 - np.cos(ts)) / ts)
    out = np.empty_like(w)
    out[:, 0] = a * w[:, 0] - b * w[:, 1]
    out[:, 1] = b * w[:, 0] + a * w[:, 1]
    out[:, 2] = th
    return out


def pose2_compose(P: Array, D: Array) -> Array:
    """``P ∘ D`` for rows of poses ``[x, y, θ]`` (broadcasting), θ wrapped."""
    c, s = np.cos(P[..., 2]), np.sin(P[..., 2])
    out = np.empty(np.broadcast_shapes(P.shape, D.shape))
    out[..., 0] = P[..., 0] + c * D[..., 0] - s * D[..., 1]
    out[..., 1] = P[..., 1] + s * D[..., 0] + c * D[..., 1]
    out[..., 2] = wrap_angle(P[..., 2] + D[..., 2])
    return out


def odometry_model(sqrt_covs: Array) -> Transition:
    r"""Joint-state transition over ``len(sqrt_covs)`` odometry steps; landmarks stay.

    ``u`` is the (s, 3) block of increments; the noise ``W`` (m, 3s) holds each step's
    increment error (``sqrt_covs`` (s, 3, 3) their lower factors):
    :math:`T \leftarrow T\,\Delta_i\,\mathrm{Exp}(w_i)`.  EKF Jacobians chain the
    per-step ones along the mean path, :math:`F_i = [[I, J R(θ_i)Δ_i],[0, 1]]`,
    :math:`G_i = \mathrm{blkdiag}(R(θ_{i+1}), 1)`.
    """
    sqrt_covs = np.asarray(sqrt_covs, dtype=float)
    s = len(sqrt_covs)
    sq = np.zeros((3 * s, 3 * s))
    for i, L in enumerate(sqrt_covs):
        sq[3 * i:3 * i + 3, 3 * i:3 * i + 3] = L

    def f(X: Array, u: Array, W: Array) -> Array:
        Y = X.copy()
        px, py, pt = X[:, 0].copy(), X[:, 1].copy(), X[:, 2].copy()
        for i in range(s):
            # E = Exp(w) (sinc forms, exact at 0), D = Δ_i ∘ E, P = P ∘ D
            vx, vy, th = W[:, 3 * i], W[:, 3 * i + 1], W[:, 3 * i + 2]
            a = np.sinc(th / np.pi)
            half = np.sin(0.5 * th)
            b = half * np.sinc(th / (2.0 * np.pi))
            ex, ey = a * vx - b * vy, b * vx + a * vy
            cu, su = math.cos(u[i, 2]), math.sin(u[i, 2])
            dx, dy = u[i, 0] + cu * ex - su * ey, u[i, 1] + su * ex + cu * ey
            c, sn = np.cos(pt), np.sin(pt)
            px += c * dx - sn * dy
            py += sn * dx + c * dy
            pt += u[i, 2] + th
        Y[:, 0], Y[:, 1], Y[:, 2] = px, py, wrap_angle(pt)
        return Y

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        n = x.shape[0]
        Fv = np.eye(3)
        Gv = np.zeros((3, 3 * s))
        p = np.asarray(x[:3], dtype=float)
        for i in range(s):
            c, sn = np.cos(p[2]), np.sin(p[2])
            dx, dy = c * u[i, 0] - sn * u[i, 1], sn * u[i, 0] + c * u[i, 1]
            Fi = np.eye(3)
            Fi[0, 2], Fi[1, 2] = -dy, dx
            p = pose2_compose(p, np.asarray(u[i], dtype=float))
            c1, s1 = np.cos(p[2]), np.sin(p[2])
            Gi = np.array([[c1, -s1, 0.0], [s1, c1, 0.0], [0.0, 0.0, 1.0]])
            Fv = Fi @ Fv
            Gv = Fi @ Gv
            Gv[:, 3 * i:3 * i + 3] = Gi
        F = np.eye(n)
        F[:3, :3] = Fv
        Gm = np.zeros((n, 3 * s))
        Gm[:3] = Gv
        return F, Gm

    return Transition(f, Noise.from_sqrt(sq), additive=False, jacobian=jacobian)


def _block_noise(covs: Array) -> Noise:
    k = len(covs)
    C = np.zeros((2 * k, 2 * k))
    for i, c in enumerate(covs):
        C[2 * i:2 * i + 2, 2 * i:2 * i + 2] = c
    return Noise.from_cov(C)


def point_in_robot(X: Array, slots: Array) -> Array:
    """Stacked ``R(φ)ᵀ (m - p)`` of the landmarks at ``slots`` from states ``X`` (m, n)."""
    cols = 3 + 2 * np.asarray(slots)
    dx = X[:, cols] - X[:, :1]
    dy = X[:, cols + 1] - X[:, 1:2]
    c, s = np.cos(X[:, 2:3]), np.sin(X[:, 2:3])
    Z = np.empty((X.shape[0], 2 * len(cols)))
    Z[:, 0::2] = c * dx + s * dy
    Z[:, 1::2] = -s * dx + c * dy
    return Z


def point_observation_model(slots: Array, covs: Array) -> Measurement:
    """Cartesian robot-frame observation of the landmarks at ``slots`` (``covs`` (k, 2, 2))."""
    slots = np.asarray(slots, dtype=int)

    def jacobian(x: Array) -> Array:
        H = np.zeros((2 * len(slots), x.shape[0]))
        c, s = np.cos(x[2]), np.sin(x[2])
        Rt = np.array([[c, s], [-s, c]])
        z = point_in_robot(x[None, :], slots)[0]
        for i, sl in enumerate(slots):
            col = 3 + 2 * int(sl)
            r = slice(2 * i, 2 * i + 2)
            H[r, 0:2] = -Rt
            H[r, 2] = [z[2 * i + 1], -z[2 * i]]
            H[r, col:col + 2] = Rt
        return H

    return Measurement(lambda X: point_in_robot(X, slots), _block_noise(covs),
                       space=Euclidean(2 * len(slots)), jacobian=jacobian)


def point_augmentation_model(n_landmarks: int, z_new: Array, covs: Array) -> Transition:
    """Append the landmarks first seen as robot-frame points ``z_new`` (2k,):
    :math:`s' = [s;\\ p + R(φ)(z + v)]`, the observation noise ``v`` a model input."""
    k = len(z_new) // 2
    n = 3 + 2 * n_landmarks

    def f(X: Array, u: Array, W: Array) -> Array:
        Z = u + W
        c, s = np.cos(X[:, 2:3]), np.sin(X[:, 2:3])
        new = np.empty((X.shape[0], 2 * k))
        new[:, 0::2] = X[:, :1] + c * Z[:, 0::2] - s * Z[:, 1::2]
        new[:, 1::2] = X[:, 1:2] + s * Z[:, 0::2] + c * Z[:, 1::2]
        return np.hstack([X, new])

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        F = np.zeros((n + 2 * k, n))
        F[:n] = np.eye(n)
        Gm = np.zeros((n + 2 * k, 2 * k))
        c, s = np.cos(x[2]), np.sin(x[2])
        for i in range(k):
            zx, zy = u[2 * i], u[2 * i + 1]
            row = n + 2 * i
            F[row, [0, 2]] = [1.0, -s * zx - c * zy]
            F[row + 1, [1, 2]] = [1.0, c * zx - s * zy]
            Gm[row:row + 2, 2 * i:2 * i + 2] = [[c, -s], [s, c]]
        return F, Gm

    return Transition(f, _block_noise(covs), additive=False, space=state_space(n_landmarks + k),
                      jacobian=jacobian)


def recorded_epochs(log: OdometryLog, max_steps: int = DEFAULT_MAX_EPOCH_STEPS) -> Array:
    """Filter epochs (chain indices): 0, every pose with observations, the last pose, and
    enough in between that no prediction compounds more than ``max_steps`` steps."""
    K = log.n_poses - 1
    ev = np.unique(np.concatenate([[0, K], log.obs_pose])).astype(np.int64)
    out = [int(ev[0])]
    for k in ev[1:]:
        while k - out[-1] > max_steps:
            out.append(out[-1] + max_steps)
        out.append(int(k))
    return np.asarray(out, dtype=np.int64)


def recorded_problem(log: OdometryLog, *, max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS,
                     variant: str | None = None) -> SlamProblem:
    """The :class:`~slam.mapping.problem.SlamProblem` of a recorded log (known ids, no truth);
    ``variant`` as in :func:`slam.kinds.planar.slam.planar_problem`."""
    sq = np.linalg.cholesky(log.odometry_cov) if len(log.odometry_cov) else np.zeros((0, 3, 3))
    models: dict[bytes, Transition] = {}   # logs often repeat one covariance
    v = PlanarVariant.of(variant, np.zeros(3))

    def motion(k0: int, k1: int, b: Any = None) -> tuple[Transition, Array]:
        key = sq[k0:k1].tobytes()
        if key not in models:
            models[key] = v.motion_model(odometry_model(sq[k0:k1]))
        return v.motion(models[key], b, log.odometry[k0:k1])

    def observe(slots: Array, index: Array) -> Measurement:
        return v.observation(point_observation_model(slots, log.obs_cov[index]), slots)

    def augment(n: int, z: Array, index: Array) -> Transition:
        return v.augment(point_augmentation_model(n, z, log.obs_cov[index]), n)

    return SlamProblem(
        x0=np.zeros(3), P0=np.zeros((3, 3)), steps=recorded_epochs(log, max_epoch_steps),
        motion=motion, observations=log.observations_at(), obs=log.obs, obs_id=log.obs_id,
        observe=observe, augment=augment, layout=v.layout, truth=None, nearest=None)


def run_recorded(log: OdometryLog, filter_name: str, *, mode: str = "local",
                 max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS,
                 filter_params: dict | None = None) -> SlamResult:
    """Run one filter over a recorded log (the one filter loop); a variant name
    (``srckf-inv``, ``ekf-fej``: :mod:`slam.kinds.planar.variants`; ``ekf-fej`` in joint
    mode only)."""
    problem = problem_for(lambda variant: recorded_problem(
        log, max_epoch_steps=max_epoch_steps, variant=variant), filter_name, mode)
    return run_problem(problem, filter_name, mode=mode, filter_params=filter_params)


def dead_reckoning_poses(log: OdometryLog) -> Array:
    """The compounded odometry, (P, 3), from the origin."""
    out = np.zeros((log.n_poses, 3))
    for k in range(1, log.n_poses):
        out[k] = pose2_compose(out[k - 1], log.odometry[k - 1])
    return out


