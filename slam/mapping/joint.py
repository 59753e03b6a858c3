r"""Vehicle-map SLAM: one mean and one (square-root) covariance over the vehicle and
every landmark seen so far, run over a :class:`~slam.kinds.planar.log.PlanarLog` (or any log turned
into a :class:`SlamProblem`, e.g. a recorded one, :mod:`slam.kinds.recorded.run`).

The filter runs on sensor epochs: every ``epoch_steps`` control steps (the sensor's
scan period) and at every step with observations.  Between epochs it predicts once
through the compounded motion model with every step's control noise as an input
(:func:`~slam.kinds.planar.models.motion_model`); at an epoch it first updates with all
re-observed landmarks in one batch, then augments the state with the new ones
(inverse observation; Bailey's order).

Two modes share this one loop (:func:`run_problem`) and differ only in the three step
functions it calls:

``joint``
    sigma points over the whole joint state, as the seed paper does (the filter's own
    ``predict``/``update`` on the joint belief);
``local``
    sigma points only over the blocks a step touches, the rest of the joint state carried
    by exact linear relations and rank-k updates of the joint factor
    (:mod:`slam.mapping.local`; EKF and the square-root sigma-point filters).

Numerical failure (loss of positive definiteness, a non-finite estimate) or a
vehicle error beyond ``diverge_m`` ends the run and is reported as a divergence in
the result; it never raises out of :func:`run_slam` / :func:`run_problem`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import Gaussian, make_filter, wrap_angle
from estimators.linalg import Array
from estimators.models import Belief, Innovation, Measurement, Transition
from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.models import (
    augmentation_model,
    motion_model,
    observation_model,
    range_bearing,
    range_bearing_jacobian,
    state_space,
)
from slam.mapping.association import gated_choice
from slam.mapping.local import Layout, check_local, local_augment, local_predict, local_update

#: The filter modes (``[filters] mode`` in a world file, ``--mode`` on the command line).
MODES: tuple[str, ...] = ("joint", "local")

#: Layout of the planar state: the pose ``[x, y, φ]``, then 2-D landmarks.
PLANAR_LAYOUT = Layout(3, 2, state_space)


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


def _nearest_neighbour(belief: Belief, z: Array, obs_cov: Array, n_lm: int,
                       gates: tuple[float, float]) -> int | None:
    """Gated association of one observation ``z`` = [r, b] (see
    :func:`slam.mapping.association.gated_choice`), linearised at the mean."""
    x = belief.mean
    slots = np.arange(n_lm)
    zhat = range_bearing(x[None, :], slots)[0].reshape(n_lm, 2)
    H = range_bearing_jacobian(x, slots)
    nu = z - zhat
    nu[:, 1] = wrap_angle(nu[:, 1])
    S = np.empty((n_lm, 2, 2))
    for s in slots:
        rows = np.r_[0, 1, 2, 3 + 2 * s, 4 + 2 * s]
        Hs = H[2 * s:2 * s + 2, rows]
        S[s] = Hs @ belief.cov_block(rows) @ Hs.T + obs_cov
    return gated_choice(nu, S, gates)


def epochs_of(log: PlanarLog, epoch_steps: int) -> Array:
    """Filter epochs: 0, every ``epoch_steps`` steps, every observation step, and K."""
    K = log.n_steps
    return np.unique(np.concatenate([np.arange(0, K + 1, epoch_steps), [K],
                                     np.asarray(log.obs_step, dtype=int)]))


@dataclass(frozen=True)
class SlamProblem:
    """A log as the filter loop sees it: the vehicle first, then the landmarks.

    Attributes
    ----------
    x0, P0 : initial vehicle mean and covariance (``P0`` may be zero).
    steps : (E,) epochs (step indices, increasing, from 0).
    motion : ``motion(k0, k1) -> (transition, u)`` from epoch step ``k0`` to ``k1``; the
        transition moves the first ``layout.nv`` coordinates of a state of any width
        and copies the rest.
    observations : step -> slice of ``obs`` / ``obs_id`` taken at that step.
    obs : (M, dz) observations; obs_id : (M,) their landmark ids.
    observe : ``observe(slots, index) -> Measurement`` of the landmarks in state slots
        ``slots`` by the observations ``obs[index]``; the measurement is of a state
        ``[vehicle; landmarks...]`` (joint mode: the whole state; local mode: the block
        ``[vehicle; landmarks in slots]``, passed with ``slots = 0..k-1``).
    augment : ``augment(n_landmarks, z_new, index) -> Transition`` into a state with the
        new landmarks appended (local mode passes ``n_landmarks = 0``).
    layout : the state's block layout and spaces.
    truth : (K + 1, >= 2) true positions by step, or ``None`` (no divergence distance).
    nearest : ``nearest(belief, z, n_landmarks, gates) -> slot | -1 | None`` for
        nearest-neighbour association, or ``None`` (ids only).
    """

    x0: Array
    P0: Array
    steps: Array
    motion: Callable[[int, int], tuple[Transition, Any]]
    observations: dict[int, slice]
    obs: Array
    obs_id: Array
    observe: Callable[[Array, Array], Measurement]
    augment: Callable[[int, Array, Array], Transition]
    layout: Layout
    truth: Array | None = None
    nearest: Callable[..., int | None] | None = None


class _JointSteps:
    """``joint`` mode: the filter's own predict/update on the whole joint belief."""

    def __init__(self, filt, problem: SlamProblem):
        self.filt, self.problem = filt, problem

    def predict(self, b: Belief, model: Transition, u: Any) -> Belief:
        return self.filt.predict(b, model, u)

    def update(self, b: Belief, slots: Array, index: Array, z: Array
               ) -> tuple[Belief, Innovation]:
        return self.filt.update(b, self.problem.observe(slots, index), z)

    def augment(self, b: Belief, n_before: int, z_new: Array, index: Array) -> Belief:
        return self.filt.predict(b, self.problem.augment(n_before, z_new, index), z_new)


class _LocalSteps:
    """``local`` mode: block-local steps (:mod:`slam.mapping.local`)."""

    def __init__(self, filt, problem: SlamProblem):
        check_local(filt)
        self.filt, self.problem, self.layout = filt, problem, problem.layout

    def predict(self, b: Belief, model: Transition, u: Any) -> Belief:
        return local_predict(self.filt, b, model, u, self.layout)

    def update(self, b: Belief, slots: Array, index: Array, z: Array
               ) -> tuple[Belief, Innovation]:
        model = self.problem.observe(np.arange(len(slots)), index)
        return local_update(self.filt, b, slots, model, z, self.layout)

    def augment(self, b: Belief, n_before: int, z_new: Array, index: Array) -> Belief:
        return local_augment(self.filt, b, self.problem.augment(0, z_new, index), z_new,
                             self.layout)


def planar_problem(log: PlanarLog, *, epoch_steps: int = 8, noise_scale: float = 1.0
                   ) -> SlamProblem:
    """The :class:`SlamProblem` of a simulated planar log (car model, range-bearing)."""
    control_cov = noise_scale * log.control_cov
    obs_cov = noise_scale * log.obs_cov
    motions: dict[int, Transition] = {}

    def motion(k0: int, k1: int) -> tuple[Transition, Array]:
        n = k1 - k0
        if n not in motions:
            motions[n] = motion_model(log.dt, log.wheelbase, control_cov, n)
        return motions[n], log.controls[k0:k1]

    def nearest(b: Belief, z: Array, n_lm: int, gates: tuple[float, float]) -> int | None:
        return _nearest_neighbour(b, z, obs_cov, n_lm, gates)

    return SlamProblem(
        x0=np.asarray(log.x0, dtype=float), P0=np.asarray(log.P0, dtype=float),
        steps=epochs_of(log, epoch_steps), motion=motion,
        observations=log.observations_at(), obs=log.obs, obs_id=log.obs_id,
        observe=lambda slots, index: observation_model(slots, obs_cov),
        augment=lambda n, z, index: augmentation_model(n, z, obs_cov),
        layout=PLANAR_LAYOUT, truth=log.truth, nearest=nearest)


def run_slam(log: PlanarLog, filter_name: str, *, association: str = "known",
             gates: tuple[float, float] = (4.0, 25.0), epoch_steps: int = 8,
             diverge_m: float = 50.0, filter_params: dict | None = None,
             noise_scale: float = 1.0, mode: str = "joint") -> SlamResult:
    """Run one SLAM filter over ``log``.

    Parameters
    ----------
    association : ``"known"`` (observation ids) or ``"nn"`` (gated nearest neighbour).
    gates : squared-Mahalanobis gates (accept, new landmark).
    epoch_steps : control steps between filter epochs (the sensor's scan period).
    noise_scale : multiplies the noise covariances the filter assumes (a plumbing
        check runs noise-free logs with tiny assumed noise).
    mode : ``"joint"`` (sigma points over the whole state) or ``"local"`` (over the
        blocks a step touches, :mod:`slam.mapping.local`).
    """
    problem = planar_problem(log, epoch_steps=epoch_steps, noise_scale=noise_scale)
    return run_problem(problem, filter_name, mode=mode, association=association, gates=gates,
                       diverge_m=diverge_m, filter_params=filter_params)


def run_problem(problem: SlamProblem, filter_name: str, *, mode: str = "joint",
                association: str = "known", gates: tuple[float, float] = (4.0, 25.0),
                diverge_m: float = 50.0, filter_params: dict | None = None) -> SlamResult:
    """The filter loop over a :class:`SlamProblem` (see :func:`run_slam`)."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; choose from {', '.join(MODES)}")
    if association not in ("known", "nn"):
        raise ValueError(f"unknown association {association!r}; choose known or nn")
    if association == "nn" and problem.nearest is None:
        raise ValueError("this log has no nearest-neighbour association; use known ids")
    filt = make_filter(filter_name, **(filter_params or {}))
    steps_of = _LocalSteps if mode == "local" else _JointSteps
    ops = steps_of(filt, problem)
    nv = problem.layout.nv
    obs_at = problem.observations
    steps = problem.steps
    P0 = problem.P0
    space0 = problem.layout.space_of(0)
    if np.any(P0):
        b: Belief = filt.init(problem.x0, space0, cov=P0)
    else:
        b = filt.init(problem.x0, space0, sqrt=np.zeros((nv, nv)))
    E = len(steps)
    poses = np.full((E, nv), np.nan)
    covs = np.full((E, nv, nv), np.nan)
    poses[0], covs[0] = b.mean[:nv], b.cov_block(np.arange(nv))
    slot_ids: list[int] = []
    slot_of: dict[int, int] = {}
    nis, dof = [], []
    failure = None
    truth = problem.truth
    t0 = time.perf_counter()
    try:
        for e in range(1, E):
            k0, k1 = int(steps[e - 1]), int(steps[e])
            model, u = problem.motion(k0, k1)
            b = ops.predict(b, model, u)
            sl = obs_at.get(k1)
            if sl is not None:
                b = _observe(ops, problem, b, sl, association, gates, slot_ids, slot_of,
                             nis, dof)
            if not np.all(np.isfinite(b.mean)):
                raise FloatingPointError("non-finite state estimate")
            poses[e], covs[e] = b.mean[:nv], b.cov_block(np.arange(nv))
            if truth is not None and np.hypot(*(b.mean[:2] - truth[k1, :2])) > diverge_m:
                raise FloatingPointError(f"vehicle error above {diverge_m} m at step {k1}")
    except (np.linalg.LinAlgError, FloatingPointError, ArithmeticError) as exc:
        failure = f"{type(exc).__name__}: {exc}"
    elapsed = time.perf_counter() - t0
    n_lm = len(slot_ids)
    nl = problem.layout.nl
    lm = b.mean[nv:nv + nl * n_lm].reshape(n_lm, nl)
    lm_cov = np.array([b.cov_block(nv + nl * s + np.arange(nl)) for s in range(n_lm)]
                      ).reshape(n_lm, nl, nl)
    return SlamResult(filter_name, steps, poses, covs, np.array(slot_ids, dtype=int), lm,
                      lm_cov, np.array(nis), np.array(dof, dtype=int), elapsed,
                      failure is not None, failure)


def _observe(ops, problem: SlamProblem, b: Belief, sl: slice, association: str,
             gates: tuple[float, float], slot_ids: list[int], slot_of: dict[int, int],
             nis: list[float], dof: list[int]) -> Belief:
    """Batch update with re-observed landmarks, then augment with new ones."""
    matched_slots, matched_z, matched_i, new_z, new_i = [], [], [], [], []
    n_before = len(slot_ids)
    Z, ids = problem.obs[sl], problem.obs_id[sl]
    for i, (z, lid) in enumerate(zip(Z, ids), start=sl.start or 0):
        if association == "known":
            slot = slot_of.get(int(lid), -1)
        else:
            slot = problem.nearest(b, z, n_before, gates)
            if slot is None:
                continue
        if slot >= 0:
            matched_slots.append(slot)
            matched_z.append(z)
            matched_i.append(i)
        else:
            new_z.append(z)
            new_i.append(i)
            slot_of[int(lid)] = n_before + len(new_z) - 1
            slot_ids.append(int(lid) if association == "known" else -1)
    if matched_slots:
        b, inn = ops.update(b, np.array(matched_slots), np.array(matched_i),
                            np.concatenate(matched_z))
        nis.append(inn.nis)
        dof.append(len(inn.nu))
    if new_z:
        b = ops.augment(b, n_before, np.concatenate(new_z), np.array(new_i))
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
