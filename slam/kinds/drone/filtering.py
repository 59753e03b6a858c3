"""The drone's filters on a log: the log as a SLAM problem through the one SLAM loop,
and the IMU-only baseline."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from estimators import BlockLayout, wrap_angle
from estimators.linalg import Array
from estimators.models import Belief
from nav.strapdown import dcm_unit, mechanise
from slam.kinds.drone.models import (
    POSE_ROWS,
    VEH_AMBIENT,
    augmentation_model,
    body_vectors,
    error_transitions,
    imu_transition,
    landmark_rows,
    observation_model,
    rae_jacobian,
    rae_of,
    state_space,
)
from slam.kinds.drone.simulate import DroneLog
from slam.kinds.drone.variants import (
    DRONE_LOCAL_FILTERS,
    GROUP_LAYOUT,
    group_space,
    invariant_augmentation,
    invariant_imu_transition,
    invariant_observation,
    split_variant,
)
from slam.mapping.association import gated_choice
from slam.mapping.batch import run_problems
from slam.mapping.problem import SlamProblem, run_problem, variant_problem, world_belief
from slam.results import SlamRun

IMU_ONLY = "imu_only"
DRONE_LAYOUT = BlockLayout.of(state_space)


# --------------------------------------------------------------------------- filtering

@dataclass(frozen=True)
class DroneEstimate(SlamRun):
    """One estimator's output at the sensor epochs.

    p, v (E, 3); q (E, 4); bias (E, 6) ``[b_g, b_a]``; pose_cov (E, 6, 6) of
    ``[δp (world frame), δθ (body frame)]`` (NaN where none); landmark_ids (L,) (``-1``
    for one created by nearest-neighbour association), landmarks (L, 3), landmark_cov
    (L, 3, 3); vehicle_var (E, 15) the error state's variances.  The
    :class:`~slam.results.SlamRun` fields: nis, nis_dof per batch update; time_s wall time
    of the ``steps`` epochs; extra_time_s (the smoother's marginals); nis_epoch (U,) the
    epoch of each update; map_series the map per epoch (filters only).
    """

    name: str
    p: Array
    v: Array
    q: Array
    bias: Array
    pose_cov: Array
    landmark_ids: Array
    landmarks: Array
    landmark_cov: Array
    vehicle_var: Array | None = None


def _nearest_neighbour(belief: Belief, z: Array, obs_cov: Array, n_lm: int,
                       gates: tuple[float, float]) -> int | None:
    """Gated association of one ``[r, az, el]`` (see
    :func:`slam.mapping.association.gated_choice`), linearised at the mean."""
    x = belief.mean
    slots = np.arange(n_lm)
    zhat = rae_of(body_vectors(x[None], slots)[0]).reshape(n_lm, 3)
    H = rae_jacobian(x, slots)
    nu = z - zhat
    nu[:, 1] = wrap_angle(nu[:, 1])
    S = np.empty((n_lm, 3, 3))
    for s in slots:
        rows = np.r_[0:3, 6:9, landmark_rows(int(s))]
        Hs = H[3 * s:3 * s + 3, rows]
        S[s] = Hs @ belief.cov_block(rows) @ Hs.T + obs_cov
    return gated_choice(nu, S, gates)


def drone_problem(log: DroneLog, *, imu_noise_scale: float = 1.0,
                  sensor_noise_scale: float = 1.0, noise_scale: float = 1.0,
                  variant: str | None = None) -> SlamProblem:
    """The drone log as a :class:`~slam.mapping.problem.SlamProblem`: epochs are the sensor
    epochs (``steps = 0..E-1``), one prediction per epoch through its IMU samples.

    ``imu_noise_scale`` / ``sensor_noise_scale`` multiply the IMU / sensor variances the
    filter assumes (world tuning); ``noise_scale`` multiplies every assumed variance,
    ``P0`` included (a plumbing check runs a noise-free log with a tiny one).
    ``variant``: ``None`` (standard error) or ``"inv"`` (right-invariant group error,
    :mod:`slam.kinds.drone.variants`).
    """
    if variant not in (None, "inv"):
        raise ValueError(f"unknown drone variant {variant!r}; choose inv")
    inv = variant == "inv"
    noise = log.imu_noise.scaled(imu_noise_scale * noise_scale)
    obs_cov = log.obs_cov * (sensor_noise_scale * noise_scale)
    imu = np.asarray(log.steps)

    def motion_input(e0: int, e1: int) -> tuple[Array, Array]:
        k0, k1 = int(imu[e0]), int(imu[e1])
        return log.gyro[k0:k1], log.accel[k0:k1]

    def motion_model(e0: int, e1: int, b: Belief, u: tuple[Array, Array]):
        n_lm = (b.mean.shape[-1] - VEH_AMBIENT) // 3
        build = invariant_imu_transition if inv else imu_transition
        return build(b.mean, n_lm, u[0], u[1], log.nav, noise)

    def motion(e0: int, e1: int, b: Belief):
        u = motion_input(e0, e1)
        return motion_model(e0, e1, b, u), u

    def observe(slots: Array, index: Array):
        m = observation_model(slots, obs_cov)
        return invariant_observation(m) if inv else m

    def augment(n: int, z: Array, index: Array):
        m = augmentation_model(n, z, obs_cov)
        return invariant_augmentation(m) if inv else m

    def nearest(b: Belief, z: Array, n_lm: int, gates: tuple[float, float]) -> int | None:
        return _nearest_neighbour(world_belief(b), z, obs_cov, n_lm, gates)

    return SlamProblem(
        x0=np.asarray(log.x0, dtype=float), P0=log.P0 * noise_scale,
        steps=np.arange(log.n_epochs), motion=motion, observations=log.observations_at(),
        obs=log.obs, obs_id=log.obs_id,
        observe=observe, augment=augment,
        layout=GROUP_LAYOUT if inv else DRONE_LAYOUT, truth=log.truth, position_dims=3,
        nearest=nearest, record_rows=POSE_ROWS, true_landmarks=log.landmarks,
        batchable=not inv, motion_input=motion_input, motion_model=motion_model)


def run_drone_filter(log: DroneLog, filter_name: str, *, association: str = "known",
                     gates: tuple[float, float] = (7.8, 30.0), diverge_m: float = 25.0,
                     imu_noise_scale: float = 1.0, sensor_noise_scale: float = 1.0,
                     noise_scale: float = 1.0, filter_params: dict | None = None,
                     mode: str = "joint") -> DroneEstimate:
    """Run one SINS/SLAM filter over ``log`` (module docstring) through the one SLAM loop
    (:func:`slam.mapping.problem.run_problem`); noise scales as :func:`drone_problem`.
    ``filter_name`` may name a variant (``srckf-inv``: :mod:`slam.kinds.drone.variants`;
    local mode for ekf, srckf, srukf and srcdkf)."""
    variant = split_variant(filter_name)[1]
    problem = variant_problem(
        lambda v: drone_problem(log, imu_noise_scale=imu_noise_scale,
                                sensor_noise_scale=sensor_noise_scale, noise_scale=noise_scale,
                                variant=v),
        filter_name, variant, mode, DRONE_LOCAL_FILTERS, group_space)
    return _estimate(filter_name, run_problem(problem, filter_name, mode=mode,
                                              association=association, gates=gates,
                                              diverge_m=diverge_m, filter_params=filter_params))


def run_drone_batch(logs: list[DroneLog], filter_name: str, *, association: str = "known",
                    gates: tuple[float, float] = (7.8, 30.0), diverge_m: float = 25.0,
                    imu_noise_scale: float = 1.0, sensor_noise_scale: float = 1.0,
                    filter_params: dict | None = None, mode: str = "joint",
                    batched: bool = True) -> list[DroneEstimate]:
    """:func:`run_drone_filter` of every log, the runs that share a layout as one batch
    (:func:`slam.mapping.batch.run_problems`: the standard-error filters in joint mode with
    known association; each result is the per-run one)."""
    variant = split_variant(filter_name)[1]
    problems = [variant_problem(
        lambda v, log=log: drone_problem(log, imu_noise_scale=imu_noise_scale,
                                         sensor_noise_scale=sensor_noise_scale, variant=v),
        filter_name, variant, mode, DRONE_LOCAL_FILTERS, group_space) for log in logs]
    results = run_problems(problems, filter_name, mode=mode, association=association,
                           gates=gates, diverge_m=diverge_m, filter_params=filter_params,
                           batched=batched)
    return [_estimate(filter_name, r) for r in results]


def _estimate(filter_name: str, r) -> DroneEstimate:
    x = r.poses
    return DroneEstimate(filter_name, x[:, 0:3], x[:, 3:6], x[:, 6:10], x[:, 10:16], r.pose_cov,
                         r.landmark_ids, r.landmarks, r.landmark_cov, r.vehicle_var,
                         nis=r.nis, nis_dof=r.nis_dof, time_s=r.time_s,
                         steps=max(r.epochs_done, 1), diverged=r.diverged, failure=r.failure,
                         nis_epoch=r.nis_epoch, map_series=r.map_series)


def imu_only(log: DroneLog, imu_noise_scale: float = 1.0, chunk: int = 100) -> DroneEstimate:
    """The IMU-only baseline: mechanisation from ``x0`` with zero bias estimates and no
    landmarks; its covariance is the EKF prediction of the 15-d error state, epoch by epoch
    (the same ``(Φ, Q)`` as the filters' prediction, computed for all epochs at once)."""
    noise = log.imu_noise.scaled(imu_noise_scale)
    nav = log.nav
    t0 = time.perf_counter()
    x0 = np.asarray(log.x0, dtype=float)
    E, n = log.n_epochs, log.samples_per_epoch
    K = int(log.steps[-1])
    w = log.gyro[:K] - x0[10:13]
    f = log.accel[:K] - x0[13:16]
    P, V, Qt = mechanise(x0[None, 0:3], x0[None, 3:6], x0[None, 6:10], w, f, nav.dt,
                         nav.gravity, nav.earth_rate, all_samples=True)
    steps = np.asarray(log.steps)
    C = dcm_unit(Qt[0, :K]).reshape(E - 1, n, 3, 3)
    w, f = w.reshape(E - 1, n, 3), f.reshape(E - 1, n, 3)
    pose_cov = np.empty((E, 6, 6))
    cov = np.asarray(log.P0, dtype=float)
    pose_cov[0] = cov[np.ix_(POSE_ROWS, POSE_ROWS)]
    for c0 in range(0, E - 1, chunk):
        Phi, Qd = error_transitions(C[c0:c0 + chunk], w[c0:c0 + chunk], f[c0:c0 + chunk],
                                    nav, noise)
        for i in range(Phi.shape[0]):
            cov = Phi[i] @ cov @ Phi[i].T + Qd[i]
            pose_cov[c0 + i + 1] = cov[np.ix_(POSE_ROWS, POSE_ROWS)]
    p, v, q = P[0, steps], V[0, steps], Qt[0, steps]
    return DroneEstimate(IMU_ONLY, p, v, q, np.zeros((E, 6)), pose_cov, np.zeros(0, int),
                         np.zeros((0, 3)), np.zeros((0, 3, 3)), nis=np.zeros(0),
                         nis_dof=np.zeros(0, int), time_s=time.perf_counter() - t0, steps=E - 1)


