"""Planar SLAM on a simulated log: the log as a :class:`~slam.mapping.problem.SlamProblem`
(car model over the epochs, range-bearing observations, gated nearest neighbour), one
filter run, and the odometry-only baseline."""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cache, partial

import numpy as np

from estimators import BlockLayout, Gaussian, make_filter, wrap_angle
from estimators.batch import run_batch
from estimators.linalg import Array
from estimators.loop import run_epochs
from estimators.models import Belief, Measurement, Transition
from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.models import (
    augmentation_model,
    motion_model,
    observation_model,
    range_bearing,
    range_bearing_jacobian,
    state_space,
)
from slam.kinds.planar.variants import (
    SIDES,
    FirstEstimates,
    group_space_of,
    invariant_augment,
    invariant_motion,
    invariant_observation,
    problem_for,
)
from slam.mapping.association import gated_choice
from slam.mapping.batch import run_problems
from slam.mapping.problem import SlamProblem, SlamResult, run_problem, world_belief

#: Layout of the planar state: the pose ``[x, y, φ]``, then 2-D landmarks.
PLANAR_LAYOUT = BlockLayout.of(state_space)


@dataclass(frozen=True)
class PlanarVariant:
    """What a variant (``None``, ``"inv"``, ``"linv"`` or ``"fej"``;
    :mod:`slam.kinds.planar.variants`) makes of a planar problem's standard-error models:
    the group error's side, or the first-estimates bookkeeping of one run."""

    side: str | None
    fej: FirstEstimates | None

    @classmethod
    def of(cls, variant: str | None, x0: Array) -> PlanarVariant:
        """The variant for a run starting at ``x0``."""
        return cls(SIDES.get(variant or ""), FirstEstimates(x0) if variant == "fej" else None)

    def motion_model(self, model: Transition) -> Transition:
        """``model`` on the group error (an invariant variant), else as it is (the part a
        problem may cache)."""
        return model if self.side is None else invariant_motion(model, self.side)

    def motion(self, model: Transition, b: Belief, u: Array) -> tuple[Transition, Array]:
        """A step's transition from the cached :meth:`motion_model` (FEJ: its Jacobian at
        the first estimates), with its input ``u``."""
        if self.fej is not None:
            return self.fej.motion(model, b.mean, u), u
        return model, u

    def observation(self, model: Measurement, slots: Array) -> Measurement:
        """``model`` of the landmarks at ``slots`` as the variant sees it."""
        if self.side is not None:
            return invariant_observation(model, self.side)
        return model if self.fej is None else self.fej.observation(model, slots)

    def augment(self, model: Transition, n: int) -> Transition:
        """``model`` appending landmarks to a state of ``n`` as the variant sees it."""
        if self.side is not None:
            return invariant_augment(model, self.side)
        return model if self.fej is None else self.fej.augment(model, n)

    @property
    def layout(self) -> BlockLayout:
        """The state's block layout (on the group for an invariant variant)."""
        return PLANAR_LAYOUT if self.side is None else BlockLayout.of(group_space_of(self.side))


def _nearest_neighbour(belief: Belief, z: Array, obs_cov: Array, n_lm: int,
                       gates: tuple[float, float]) -> int | None:
    """Gated association of one observation ``z`` = [r, b] (see
    :func:`slam.mapping.association.gated_choice`), linearised at the mean (the covariance
    in the world frame for a group-error belief)."""
    belief = world_belief(belief)
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


def planar_problem(log: PlanarLog, *, epoch_steps: int = 8, noise_scale: float = 1.0,
                   variant: str | None = None) -> SlamProblem:
    """The :class:`SlamProblem` of a simulated planar log (car model, range-bearing).

    ``variant``: ``None`` (standard error), ``"inv"`` / ``"linv"`` (right- / left-invariant
    group error) or ``"fej"`` (first-estimates Jacobians); see
    :mod:`slam.kinds.planar.variants`.
    """
    control_cov = noise_scale * log.control_cov
    obs_cov = noise_scale * log.obs_cov
    v = PlanarVariant.of(variant, np.asarray(log.x0, dtype=float))

    @cache
    def steps_model(n: int) -> Transition:  # one per epoch length, built once
        return v.motion_model(motion_model(log.dt, log.wheelbase, control_cov, n))

    def motion(k0: int, k1: int, b: Belief) -> tuple[Transition, Array]:
        return v.motion(steps_model(k1 - k0), b, log.controls[k0:k1])

    def observe(slots: Array, index: Array):
        return v.observation(observation_model(slots, obs_cov), slots)

    def augment(n: int, z: Array, index: Array) -> Transition:
        return v.augment(augmentation_model(n, z, obs_cov), n)

    def nearest(b: Belief, z: Array, n_lm: int, gates: tuple[float, float]) -> int | None:
        return _nearest_neighbour(b, z, obs_cov, n_lm, gates)

    return SlamProblem(
        x0=np.asarray(log.x0, dtype=float), P0=np.asarray(log.P0, dtype=float),
        steps=epochs_of(log, epoch_steps), motion=motion,
        observations=log.observations_at(), obs=log.obs, obs_id=log.obs_id,
        observe=observe, augment=augment, layout=v.layout,
        truth=log.truth, nearest=nearest, true_landmarks=log.landmarks,
        batchable=variant in (None, "inv", "linv"))


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
        blocks a step touches, :meth:`estimators.Filter.partitioned`).

    ``filter_name`` may name a variant (``srckf-inv``, ``ekf-fej``, ...;
    :mod:`slam.kinds.planar.variants`): the base filter on the variant's problem.
    """
    problem = problem_for(lambda variant: planar_problem(
        log, epoch_steps=epoch_steps, noise_scale=noise_scale, variant=variant),
        filter_name, mode)
    return run_problem(problem, filter_name, mode=mode, association=association, gates=gates,
                       diverge_m=diverge_m, filter_params=filter_params)


def run_slam_batch(logs: list[PlanarLog], filter_name: str, *, association: str = "known",
                   gates: tuple[float, float] = (4.0, 25.0), epoch_steps: int = 8,
                   diverge_m: float = 50.0, filter_params: dict | None = None,
                   mode: str = "joint", batched: bool = True) -> list[SlamResult]:
    """:func:`run_slam` of every log, the runs that share a layout as one batch
    (:func:`slam.mapping.batch.run_problems`; each result is the per-run one)."""
    problems = [problem_for(lambda variant, log=log: planar_problem(
        log, epoch_steps=epoch_steps, variant=variant), filter_name, mode) for log in logs]
    return run_problems(problems, filter_name, mode=mode, association=association, gates=gates,
                        diverge_m=diverge_m, filter_params=filter_params, batched=batched)


def dead_reckoning(log: PlanarLog, steps: Array) -> tuple[Array, Array, str | None]:
    """Odometry only: the EKF prediction of the vehicle from the noisy controls, through the
    one filter loop with no measurements.

    Returns poses (E, 3) and covariances (E, 3, 3) at the epochs ``steps`` (NaN after a
    numerical failure) and the failure's reason (``None`` if none).
    """
    E = len(steps)
    poses, covs = np.full((E, 3), np.nan), np.full((E, 3, 3), np.nan)

    def record(e: int, b: Belief) -> None:
        poses[e], covs[e] = b.mean, b.cov

    # one model per epoch length, built once, as the filters keep them
    steps_model = cache(partial(motion_model, log.dt, log.wheelbase, log.control_cov))

    def transition(e: int, b: Belief) -> tuple[Transition, Array]:
        k0, k1 = int(steps[e - 1]), int(steps[e])
        return steps_model(k1 - k0), log.controls[k0:k1]

    b0 = Gaussian(np.asarray(log.x0, dtype=float), np.asarray(log.P0, dtype=float),
                  state_space(0))
    out = run_epochs(make_filter("ekf"), b0, E, transition=transition, record=record,
                     correct=lambda e, b: (b, []))
    return poses, covs, out.failure


def dead_reckoning_batch(logs: list[PlanarLog], steps: list[Array], batched: bool = True
                         ) -> list[tuple[Array, Array, str | None, float]]:
    """:func:`dead_reckoning` of every log (with its wall time), the logs with the same
    epochs as one batch (the car model broadcasts over runs); each result is the per-run
    one."""
    if not batched or len(logs) == 1:
        out = []
        for log, st in zip(logs, steps):
            t0 = time.perf_counter()
            poses, covs, failure = dead_reckoning(log, st)
            out.append((poses, covs, failure, time.perf_counter() - t0))
        return out
    groups: dict[bytes, list[int]] = {}
    for i, st in enumerate(steps):
        groups.setdefault(np.asarray(st, dtype=np.int64).tobytes(), []).append(i)
    results: list = [None] * len(logs)
    for idx in groups.values():
        if len(idx) == 1:
            results[idx[0]] = dead_reckoning_batch([logs[idx[0]]], [steps[idx[0]]], False)[0]
            continue
        group = [logs[i] for i in idx]
        for i, r in zip(idx, _dead_reckoning_group(group, steps[idx[0]])):
            results[i] = r
    return results


def _dead_reckoning_group(logs: list[PlanarLog], steps: Array
                          ) -> list[tuple[Array, Array, str | None, float]]:
    B, E = len(logs), len(steps)
    poses, covs = np.full((B, E, 3), np.nan), np.full((B, E, 3, 3), np.nan)
    log0 = logs[0]
    steps_model = cache(partial(motion_model, log0.dt, log0.wheelbase, log0.control_cov))
    controls = np.stack([log.controls for log in logs])

    def record(e: int, b: Belief, live: Array) -> None:
        poses[live, e], covs[live, e] = b.mean, b.cov

    def transition(e: int, b: Belief, live: Array) -> tuple[Transition, Array]:
        k0, k1 = int(steps[e - 1]), int(steps[e])
        return steps_model(k1 - k0), controls[live, k0:k1]

    b0 = Gaussian(np.stack([np.asarray(log.x0, dtype=float) for log in logs]),
                  np.stack([np.asarray(log.P0, dtype=float) for log in logs]), state_space(0))
    outs = run_batch(make_filter("ekf"), b0, E, transition=transition, record=record,
                     correct=lambda e, b, live: (b, []))
    return [(poses[r], covs[r], o.failure, o.time_s) for r, o in enumerate(outs)]
