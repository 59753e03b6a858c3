r"""Joint vehicle-map SLAM: one mean and one (square-root) covariance over the vehicle
and every landmark seen so far, run over a :class:`~slam.log.PlanarLog`.

The filter runs on sensor epochs: every ``epoch_steps`` control steps (the sensor's
scan period) and at every step with observations.  Between epochs it predicts once
through the compounded car model with every step's control noise as an input
(:func:`~slam.planar_models.motion_model`); at an epoch it first updates with all
re-observed landmarks in one batch, then augments the state with the new ones
(inverse observation; Bailey's order).  Sigma points are drawn over the
whole joint state (``joint`` mode, as the seed paper does): the seam for a
block-local mode is :func:`run_slam`'s ``step`` functions, which see only beliefs
and models.

Numerical failure (loss of positive definiteness, a non-finite estimate) or a
vehicle error beyond ``diverge_m`` ends the run and is reported as a divergence in
the result; it never raises out of :func:`run_slam`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from estimators import Gaussian, SqrtGaussian, make_filter
from estimators.linalg import Array
from estimators.models import Belief

from .log import PlanarLog
from .planar_models import (
    augmentation_model,
    motion_model,
    observation_model,
    range_bearing,
    range_bearing_jacobian,
    state_space,
)


@dataclass(frozen=True)
class SlamResult:
    """What one filter produced on one log.

    Attributes
    ----------
    name : str
    steps : (E,) the epochs (control-step indices, from 0 to K).
    poses : (E, 3) vehicle means per epoch (NaN after a divergence).
    pose_cov : (E, 3, 3) vehicle covariances per epoch.
    landmark_ids : (L,) ids of the mapped landmarks (``-1`` for a landmark created by
        nearest-neighbour association, whose true id the filter cannot know).
    landmarks : (L, 2) final landmark means; landmark_cov : (L, 2, 2).
    nis : (U,) normalised innovation squared per batch update; nis_dof : (U,).
    time_s : wall time of the filter loop.
    diverged : bool; failure : reason or ``None``.
    """

    name: str
    steps: Array
    poses: Array
    pose_cov: Array
    landmark_ids: Array
    landmarks: Array
    landmark_cov: Array
    nis: Array
    nis_dof: Array
    time_s: float
    diverged: bool
    failure: str | None


def _rows_cov(belief: Belief, rows: Array) -> Array:
    """Covariance block of the given state rows, without forming the joint P."""
    if isinstance(belief, SqrtGaussian):
        S = belief.sqrt[rows]
        return S @ S.T
    return belief.cov[np.ix_(rows, rows)]


def _nearest_neighbour(belief: Belief, z: Array, obs_cov: Array, n_lm: int,
                       gates: tuple[float, float]) -> int | None:
    """Bailey-style gated association of one observation ``z`` = [r, b].

    Returns the slot of the landmark with the smallest normalised distance if its
    NIS is below ``gates[0]``, ``-1`` for a new landmark if every NIS exceeds
    ``gates[1]``, else ``None`` (ambiguous: ignored).  Linearised at the mean.
    """
    if n_lm == 0:
        return -1
    x = belief.mean
    slots = np.arange(n_lm)
    zhat = range_bearing(x[None, :], slots)[0].reshape(n_lm, 2)
    H = range_bearing_jacobian(x, slots)
    best, best_nd, best_nis = None, np.inf, np.inf
    for s in slots:
        rows = np.r_[0, 1, 2, 3 + 2 * s, 4 + 2 * s]
        Hs = H[2 * s:2 * s + 2, rows]
        Sm = Hs @ _rows_cov(belief, rows) @ Hs.T + obs_cov
        v = z - zhat[s]
        v[1] = (v[1] + np.pi) % (2 * np.pi) - np.pi
        nis = float(v @ np.linalg.solve(Sm, v))
        nd = nis + np.log(np.linalg.det(Sm))
        if nis < gates[0] and nd < best_nd:
            best, best_nd = int(s), nd
        best_nis = min(best_nis, nis)
    if best is not None:
        return best
    return -1 if best_nis > gates[1] else None


def epochs_of(log: PlanarLog, epoch_steps: int) -> Array:
    """Filter epochs: 0, every ``epoch_steps`` steps, every observation step, and K."""
    K = log.n_steps
    return np.unique(np.concatenate([np.arange(0, K + 1, epoch_steps), [K],
                                     np.asarray(log.obs_step, dtype=int)]))


def run_slam(log: PlanarLog, filter_name: str, *, association: str = "known",
             gates: tuple[float, float] = (4.0, 25.0), epoch_steps: int = 8,
             diverge_m: float = 50.0, filter_params: dict | None = None,
             noise_scale: float = 1.0) -> SlamResult:
    """Run one joint SLAM filter over ``log``.

    Parameters
    ----------
    association : ``"known"`` (observation ids) or ``"nn"`` (gated nearest neighbour).
    gates : squared-Mahalanobis gates (accept, new landmark).
    epoch_steps : control steps between filter epochs (the sensor's scan period).
    noise_scale : multiplies the noise covariances the filter assumes (a plumbing
        check runs noise-free logs with tiny assumed noise).
    """
    filt = make_filter(filter_name, **(filter_params or {}))
    control_cov = noise_scale * log.control_cov
    obs_cov = noise_scale * log.obs_cov
    motions: dict[int, object] = {}
    obs_at = log.observations_at()
    steps = epochs_of(log, epoch_steps)
    P0 = np.asarray(log.P0, dtype=float)
    if np.any(P0):
        b: Belief = filt.init(log.x0, state_space(0), cov=P0)
    else:
        b = filt.init(log.x0, state_space(0), sqrt=np.zeros((3, 3)))
    E = len(steps)
    poses = np.full((E, 3), np.nan)
    covs = np.full((E, 3, 3), np.nan)
    poses[0], covs[0] = b.mean[:3], _rows_cov(b, np.arange(3))
    slot_ids: list[int] = []
    slot_of: dict[int, int] = {}
    nis, dof = [], []
    failure = None
    t0 = time.perf_counter()
    try:
        for e in range(1, E):
            k0, k1 = int(steps[e - 1]), int(steps[e])
            n = k1 - k0
            if n not in motions:
                motions[n] = motion_model(log.dt, log.wheelbase, control_cov, n)
            b = filt.predict(b, motions[n], log.controls[k0:k1])
            sl = obs_at.get(k1)
            if sl is not None:
                b = _observe(filt, b, log.obs[sl], log.obs_id[sl], obs_cov, association,
                             gates, slot_ids, slot_of, nis, dof)
            if not np.all(np.isfinite(b.mean)):
                raise FloatingPointError("non-finite state estimate")
            poses[e], covs[e] = b.mean[:3], _rows_cov(b, np.arange(3))
            if log.truth is not None and np.hypot(*(b.mean[:2] - log.truth[k1, :2])
                                                  ) > diverge_m:
                raise FloatingPointError(f"vehicle error above {diverge_m} m at step {k1}")
    except (np.linalg.LinAlgError, FloatingPointError, ArithmeticError) as exc:
        failure = f"{type(exc).__name__}: {exc}"
    elapsed = time.perf_counter() - t0
    n_lm = len(slot_ids)
    lm = b.mean[3:3 + 2 * n_lm].reshape(n_lm, 2)
    lm_cov = np.array([_rows_cov(b, np.r_[3 + 2 * s, 4 + 2 * s]) for s in range(n_lm)]
                      ).reshape(n_lm, 2, 2)
    return SlamResult(filter_name, steps, poses, covs, np.array(slot_ids, dtype=int), lm,
                      lm_cov, np.array(nis), np.array(dof, dtype=int), elapsed,
                      failure is not None, failure)


def _observe(filt, b: Belief, Z: Array, ids: Array, obs_cov: Array, association: str,
             gates: tuple[float, float], slot_ids: list[int], slot_of: dict[int, int],
             nis: list[float], dof: list[int]) -> Belief:
    """Batch update with re-observed landmarks, then augment with new ones."""
    matched_slots, matched_z, new_z = [], [], []
    n_before = len(slot_ids)
    for z, lid in zip(Z, ids):
        if association == "known":
            slot = slot_of.get(int(lid), -1)
        else:
            slot = _nearest_neighbour(b, z, obs_cov, n_before, gates)
            if slot is None:
                continue
        if slot >= 0:
            matched_slots.append(slot)
            matched_z.append(z)
        else:
            new_z.append(z)
            slot_of[int(lid)] = n_before + len(new_z) - 1
            slot_ids.append(int(lid) if association == "known" else -1)
    if matched_slots:
        model = observation_model(np.array(matched_slots), obs_cov)
        b, inn = filt.update(b, model, np.concatenate(matched_z))
        nis.append(inn.nis)
        dof.append(2 * len(matched_slots))
    if new_z:
        z_new = np.concatenate(new_z)
        b = filt.predict(b, augmentation_model(n_before, z_new, obs_cov), z_new)
    return b


def dead_reckoning(log: PlanarLog, steps: Array) -> tuple[Array, Array]:
    """Odometry only: the EKF prediction of the vehicle from the noisy controls.

    Returns poses (E, 3) and covariances (E, 3, 3) at the epochs ``steps``.
    """
    from estimators.ekf import ekf_predict

    b = Gaussian(np.asarray(log.x0, dtype=float), np.asarray(log.P0, dtype=float),
                 state_space(0))
    poses, covs = np.empty((len(steps), 3)), np.empty((len(steps), 3, 3))
    poses[0], covs[0] = b.mean, b.cov
    for e in range(1, len(steps)):
        k0, k1 = int(steps[e - 1]), int(steps[e])
        motion = motion_model(log.dt, log.wheelbase, log.control_cov, k1 - k0)
        b = ekf_predict(b, motion, log.controls[k0:k1])
        poses[e], covs[e] = b.mean, b.cov
    return poses, covs
