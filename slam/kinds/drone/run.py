r"""Drone SINS/SLAM scenario: simulate, filter, smooth, score, summarise.

One Monte Carlo run (:func:`run_once`):

1. **Truth** (deterministic per world, cached per process): the terrain mesh
   (:func:`build_terrain`), the landmarks placed on it, and the flight
   (:func:`slam.kinds.drone.flight.fly`): Bailey-style steering through the waypoints at a constant
   height above the ground, multirotor attitude, error-free IMU readings whose
   mechanisation *is* the truth.
2. **Log** (:func:`simulate_drone`, from the run's seed): IMU biases, bias random walks
   and white noise (:func:`nav.imu_errors.corrupt_imu`); landmark observations
   ``[range, azimuth, elevation]`` in the body frame at every sensor epoch, for the
   landmarks within range, inside the field of view and - with ``line_of_sight`` - not
   hidden by the terrain (segment-mesh intersection); the filters' initial state drawn
   about the truth from the initial covariance.
3. **Estimators** on the same log: every filter in joint mode
   (:func:`run_drone_filter`: one prediction per sensor epoch through its IMU samples,
   batch update with the re-observed landmarks, then augmentation with the new ones;
   :mod:`slam.kinds.drone.models`), the IMU-only baseline (:func:`imu_only`: pure
   mechanisation from the initial state with zero bias estimates, covariance by the
   EKF's prediction) and the GTSAM smoother (:mod:`slam.kinds.drone.reference`).
4. **Scores** (:class:`DroneScores`) at the sensor epochs: position error (ENU, m) and
   its own σ; roll/pitch/yaw error (aerospace Z-Y-X Euler angles of ``q_nb`` with body
   forward-left-up: roll about x, pitch about y, positive nose-down; yaw from east,
   counter-clockwise); NEES of the 3-dof position and of the 6-dof pose
   ``[δp, δθ]`` (δθ body-frame); final landmark errors; NIS.

Numerical failure or a position error above ``divergence_m`` ends a filter's run; it is
reported as diverged, never raised.  :func:`summarize_drone` builds the ``summary.json``
dict: the headline ANEES is the **3-dof position** ANEES (``anees``, band
``anees_bounds_95``); the 6-dof pose ANEES is reported next to it (``anees_pose6``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from estimators import wrap_angle
from estimators.linalg import Array
from estimators.models import Belief
from nav.euler import euler_error_jacobian, q_to_euler_zyx
from nav.imu_errors import ImuErrors, corrupt_imu
from nav.quaternion import qconj, qexp, qmul, qrotate
from nav.strapdown import dcm_unit, earth_rate_enu, gravity_enu, mechanise
from nav.terrain import Terrain
from slam.kinds.drone.flight import FlightPlan, Trajectory, fly
from slam.kinds.drone.models import (
    POSE_ROWS,
    QUAT,
    VEH_AMBIENT,
    VEH_DIM,
    ImuNoise,
    NavFrame,
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
from slam.mapping.association import gated_choice
from slam.mapping.local import Layout
from slam.mapping.problem import SlamProblem, run_problem
from slam.results import REFERENCE, RunOutcome
from slam.scoring import anees_stats, nees_series, nis_and_timing

IMU_ONLY = "imu_only"
DRONE_LAYOUT = Layout(VEH_AMBIENT, 3, state_space)
AXES = ("x", "y", "z")
ATT_AXES = ("roll", "pitch", "yaw")
FILTER_DESCRIPTIONS = {
    "ekf": "EKF-SLAM: error-state EKF, quaternion retracted by multiplication",
    "ckf": "cubature Kalman filter (dense covariance)",
    "ukf": "unscented Kalman filter (dense covariance)",
    "cdkf": "central-difference Kalman filter (dense covariance)",
    "srckf": "quaternion SRCKF-SLAM (the paper's): square-root cubature filter",
    "srukf": "quaternion SRUKF-SLAM: square-root unscented filter",
    "srcdkf": "quaternion SRCDKF-SLAM: square-root central-difference filter",
    "svdckf": "cubature Kalman filter with an SVD-factored covariance",
}


# --------------------------------------------------------------------------- truth

@lru_cache(maxsize=8)
def build_terrain(spec: Any, bounds: tuple[float, float, float, float]) -> Terrain:
    """The world's ground mesh (a :class:`slam.kinds.drone.world.TerrainSpec` and the map bounds).

    Flat and hills meshes cover the bounds plus ``margin_m``; a mesh file is read as is.
    """
    m = spec.margin_m
    ext = (bounds[0] - m, bounds[1] + m, bounds[2] - m, bounds[3] + m)
    if spec.kind == "flat":
        return Terrain.flat(ext, spec.base_height_m)
    if spec.kind == "hills":
        return Terrain.hills(ext, spec.hill_centres, spec.hill_amplitude_m, spec.hill_width_m,
                             spec.base_height_m, spec.grid_spacing_m)
    return Terrain.from_file(spec.mesh_path)


def terrain_of(world) -> Terrain:
    """The terrain of ``world``; a mesh that does not cover the map raises ``WorldError``."""
    from worlds.schema import WorldError

    try:
        return build_terrain(world.terrain, tuple(world.map.bounds_m))
    except ValueError as exc:
        raise WorldError(world.source or world.name, "terrain.mesh_file", str(exc),
                         world.terrain.mesh_file) from None


def flight_plan(world) -> FlightPlan:
    """The :class:`~slam.kinds.drone.flight.FlightPlan` of a drone world."""
    veh = world.vehicle
    return FlightPlan(
        waypoints=tuple((float(x), float(y)) for x, y in world.map.waypoints),
        start_xy=tuple(map(float, veh.start_xy)),
        start_heading=float(veh.start_heading_rad),
        speed=veh.speed_mps,
        max_turn_rate=veh.max_turn_rate_rad_s,
        max_turn_accel=veh.max_turn_accel_rad_s2,
        steer_gain=veh.steer_gain_per_s,
        at_waypoint=veh.at_waypoint_m,
        loops=veh.loops,
        height_above_ground=veh.height_above_ground_m,
        altitude_smoothing_s=veh.altitude_smoothing_s,
        dt=world.imu.dt_s,
        drag_per_s=veh.drag_per_s,
    )


def nav_frame(world) -> NavFrame:
    imu = world.imu
    wie = earth_rate_enu(imu.latitude_rad) if imu.earth_rate else None
    return NavFrame(imu.dt_s, gravity_enu(imu.gravity_mps2), wie)


@lru_cache(maxsize=8)
def _truth(plan: FlightPlan, spec: Any, bounds: tuple, landmarks_xy: tuple, g: float,
           wie: tuple | None) -> tuple[Trajectory, Array]:
    terrain = build_terrain(spec, bounds)
    lm = np.array(landmarks_xy, dtype=float).reshape(-1, 2)
    z = terrain.height(lm)
    if not np.all(np.isfinite(z)):
        i = int(np.flatnonzero(~np.isfinite(z))[0])
        raise ValueError(f"landmark {i} {lm[i].tolist()} is outside the terrain mesh")
    traj = fly(plan, terrain.height, gravity_enu(g), None if wie is None else np.array(wie))
    return traj, np.column_stack([lm, z])


def truth_of(world) -> tuple[Trajectory, Array]:
    """``(trajectory, landmarks (N, 3))`` of ``world`` (deterministic; cached).

    Raises ``WorldError`` naming the key when the path cannot be flown or a landmark lies
    off the terrain.
    """
    from worlds.schema import WorldError

    terrain_of(world)  # mesh problems are reported against their key
    wie = nav_frame(world).earth_rate
    try:
        return _truth(flight_plan(world), world.terrain, tuple(world.map.bounds_m),
                      tuple(map(tuple, world.map.landmarks.tolist())),
                      float(world.imu.gravity_mps2), None if wie is None else tuple(wie))
    except ValueError as exc:
        key = "map.landmarks" if "landmark" in str(exc) else "map.waypoints"
        raise WorldError(world.source or world.name, key, str(exc)) from None


# --------------------------------------------------------------------------- the log

@dataclass(frozen=True)
class DroneLog:
    """Everything the estimators see, plus the truth at the sensor epochs.

    IMU: ``gyro``, ``accel`` (K, 3) measured samples, ``nav`` (dt, gravity, Earth rate),
    ``imu_noise`` the world's densities.  Epochs: ``steps`` (E,) IMU sample index of each
    sensor epoch (``steps[e] = e·n``), ``times`` (E,) s.  Observations (sorted by epoch,
    then id): ``obs_epoch`` (M,), ``obs_id`` (M,), ``obs`` (M, 3) ``[r, az, el]``,
    ``obs_cov`` (3, 3).  Start: ``x0`` (16,) the filters' initial state, ``P0`` (15, 15)
    its covariance.  Truth at the epochs: ``truth`` (E, 16) ``[p, v, q, b_g, b_a]``;
    ``landmarks`` (N, 3); ``loop_end_times`` (loops,) s.
    """

    nav: NavFrame
    samples_per_epoch: int
    steps: Array
    times: Array
    gyro: Array
    accel: Array
    imu_noise: ImuNoise
    obs_epoch: Array
    obs_id: Array
    obs: Array
    obs_cov: Array
    x0: Array
    P0: Array
    truth: Array
    landmarks: Array
    loop_end_times: Array

    @property
    def n_epochs(self) -> int:
        return len(self.steps)

    def observations_at(self) -> dict[int, slice]:
        """Epoch -> slice of its observations."""
        out: dict[int, slice] = {}
        if len(self.obs_epoch) == 0:
            return out
        e = np.asarray(self.obs_epoch)
        starts = np.flatnonzero(np.r_[True, e[1:] != e[:-1]])
        ends = np.r_[starts[1:], len(e)]
        for s, t in zip(starts, ends):
            out[int(e[s])] = slice(int(s), int(t))
        return out


def initial_covariance(world) -> Array:
    """``P0`` (15, 15) of ``[δp, δv, δθ, δb_g, δb_a]`` (attitude body-frame)."""
    veh, imu = world.vehicle, world.imu
    d = np.concatenate([
        np.full(3, veh.initial_sigma_pos_m), np.full(3, veh.initial_sigma_vel_mps),
        [veh.initial_sigma_roll_pitch_rad, veh.initial_sigma_roll_pitch_rad,
         veh.initial_sigma_yaw_rad],
        np.full(3, imu.gyro_bias_sigma), np.full(3, imu.accel_bias_sigma)])
    return np.diag(d**2)


def imu_noise_of(world) -> ImuNoise:
    imu = world.imu
    return ImuNoise(imu.gyro_arw, imu.accel_vrw, imu.gyro_bias_rw, imu.accel_bias_rw)


def observe(world, p: Array, q: Array, landmarks: Array, terrain: Terrain | None,
            rng: np.random.Generator, noise_scale: float = 1.0
            ) -> tuple[Array, Array, Array]:
    """Observations from poses ``p`` (E, 3), ``q`` (E, 4) at epochs 1..E-1.

    Returns ``(epoch, id, [r, az, el])`` sorted by epoch then id; the noise is drawn in
    that order.
    """
    sen = world.sensor
    d = qrotate(qconj(q[:, None, :]), landmarks[None] - p[:, None])  # (E, N, 3)
    z = rae_of(d)
    seen = ((z[..., 0] >= sen.min_range_m) & (z[..., 0] <= sen.max_range_m)
            & (np.abs(z[..., 1]) <= sen.fov_azimuth_half_rad)
            & (np.abs(z[..., 2]) <= sen.fov_elevation_half_rad))
    seen[0] = False
    e, j = np.nonzero(seen)
    if sen.line_of_sight and terrain is not None and e.size:
        clear = terrain.line_of_sight(p[e], landmarks[j], sen.los_margin_m)
        e, j = e[clear], j[clear]
    sig = noise_scale * np.array([sen.sigma_range_m, sen.sigma_azimuth_rad,
                                  sen.sigma_elevation_rad])
    obs = z[e, j] + rng.standard_normal((e.size, 3)) * sig
    obs[:, 1] = wrap_angle(obs[:, 1])
    return e.astype(np.int64), j.astype(np.int64), obs


def simulate_drone(world, rng: np.random.Generator, *, noise_scale: float = 1.0) -> DroneLog:
    """One run's log.  ``noise_scale`` multiplies every error actually applied (IMU
    errors, observation noise, initial-state offset); ``0`` gives a noise-free log.  The
    log's ``P0``, ``obs_cov`` and ``imu_noise`` always state the world's nominal values.

    Draw order: IMU errors (:func:`~nav.imu_errors.corrupt_imu`), observation noise, initial
    offset.
    """
    traj, lms = truth_of(world)
    nav = nav_frame(world)
    n = world.samples_per_epoch
    E = traj.n_samples // n + 1
    steps = np.arange(E, dtype=np.int64) * n
    K = int(steps[-1])
    imu, sen = world.imu, world.sensor
    errors = ImuErrors(imu.gyro_bias_sigma, imu.gyro_bias_rw, imu.gyro_arw,
                       imu.accel_bias_sigma, imu.accel_bias_rw, imu.accel_vrw)
    meas = corrupt_imu(traj.gyro[:K], traj.accel[:K], traj.dt, errors, rng, noise_scale)
    truth = np.hstack([traj.p[steps], traj.v[steps], traj.q[steps], meas.bias_gyro[steps],
                       meas.bias_accel[steps]])
    terrain = terrain_of(world) if sen.line_of_sight else None
    obs_epoch, obs_id, obs = observe(world, truth[:, 0:3], truth[:, 6:10], lms, terrain, rng,
                                     noise_scale)
    P0 = initial_covariance(world)
    delta = rng.standard_normal(VEH_DIM) * np.sqrt(np.diag(P0)) * noise_scale
    x0 = np.concatenate([truth[0, 0:3] + delta[0:3], truth[0, 3:6] + delta[3:6],
                         qmul(truth[0, 6:10], qexp(delta[6:9])), np.zeros(6)])
    return DroneLog(
        nav=nav, samples_per_epoch=n, steps=steps, times=steps * traj.dt,
        gyro=meas.gyro, accel=meas.accel, imu_noise=imu_noise_of(world),
        obs_epoch=obs_epoch, obs_id=obs_id, obs=obs,
        obs_cov=np.diag([sen.sigma_range_m, sen.sigma_azimuth_rad,
                         sen.sigma_elevation_rad]) ** 2,
        x0=x0, P0=P0, truth=truth, landmarks=lms,
        loop_end_times=traj.loop_end_steps * traj.dt,
    )


# --------------------------------------------------------------------------- filtering

@dataclass(frozen=True)
class DroneEstimate:
    """One estimator's output at the sensor epochs.

    p, v (E, 3); q (E, 4); bias (E, 6) ``[b_g, b_a]``; pose_cov (E, 6, 6) of
    ``[δp (world frame), δθ (body frame)]`` (NaN where none); landmark_ids (L,) (``-1``
    for one created by nearest-neighbour association), landmarks (L, 3), landmark_cov
    (L, 3, 3); nis, nis_dof per batch update; time_s wall time of ``steps`` epochs;
    extra_time_s (the smoother's marginals).
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
    nis: Array
    nis_dof: Array
    time_s: float
    steps: int
    diverged: bool = False
    failure: str | None = None
    extra_time_s: float = 0.0


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
                  sensor_noise_scale: float = 1.0, noise_scale: float = 1.0) -> SlamProblem:
    """The drone log as a :class:`~slam.mapping.problem.SlamProblem`: epochs are the sensor
    epochs (``steps = 0..E-1``), one prediction per epoch through its IMU samples.

    ``imu_noise_scale`` / ``sensor_noise_scale`` multiply the IMU / sensor variances the
    filter assumes (world tuning); ``noise_scale`` multiplies every assumed variance,
    ``P0`` included (a plumbing check runs a noise-free log with a tiny one).
    """
    noise = log.imu_noise.scaled(imu_noise_scale * noise_scale)
    obs_cov = log.obs_cov * (sensor_noise_scale * noise_scale)
    imu = np.asarray(log.steps)

    def motion(e0: int, e1: int, b: Belief):
        k0, k1 = int(imu[e0]), int(imu[e1])
        u = (log.gyro[k0:k1], log.accel[k0:k1])
        n_lm = (b.mean.size - VEH_AMBIENT) // 3
        return imu_transition(b.mean, n_lm, u[0], u[1], log.nav, noise), u

    def nearest(b: Belief, z: Array, n_lm: int, gates: tuple[float, float]) -> int | None:
        return _nearest_neighbour(b, z, obs_cov, n_lm, gates)

    return SlamProblem(
        x0=np.asarray(log.x0, dtype=float), P0=log.P0 * noise_scale,
        steps=np.arange(log.n_epochs), motion=motion, observations=log.observations_at(),
        obs=log.obs, obs_id=log.obs_id,
        observe=lambda slots, index: observation_model(slots, obs_cov),
        augment=lambda n, z, index: augmentation_model(n, z, obs_cov),
        layout=DRONE_LAYOUT, vehicle_dim=VEH_DIM, truth=log.truth, position_dims=3,
        nearest=nearest, record_rows=POSE_ROWS)


def run_drone_filter(log: DroneLog, filter_name: str, *, association: str = "known",
                     gates: tuple[float, float] = (7.8, 30.0), diverge_m: float = 25.0,
                     imu_noise_scale: float = 1.0, sensor_noise_scale: float = 1.0,
                     noise_scale: float = 1.0, filter_params: dict | None = None,
                     mode: str = "joint") -> DroneEstimate:
    """Run one SINS/SLAM filter over ``log`` (module docstring) through the one SLAM loop
    (:func:`slam.mapping.problem.run_problem`); noise scales as :func:`drone_problem`."""
    problem = drone_problem(log, imu_noise_scale=imu_noise_scale,
                            sensor_noise_scale=sensor_noise_scale, noise_scale=noise_scale)
    r = run_problem(problem, filter_name, mode=mode, association=association, gates=gates,
                    diverge_m=diverge_m, filter_params=filter_params)
    x = r.poses
    return DroneEstimate(filter_name, x[:, 0:3], x[:, 3:6], x[:, 6:10], x[:, 10:16], r.pose_cov,
                         r.landmark_ids, r.landmarks, r.landmark_cov, r.nis, r.nis_dof,
                         r.time_s, max(r.epochs_done, 1), r.diverged, r.failure)


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
                         np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0, int),
                         time.perf_counter() - t0, E - 1)


# --------------------------------------------------------------------------- scoring

@dataclass(frozen=True)
class DroneScores:
    """One estimator on one run, reduced (at the sensor epochs).

    err_pos (E, 3) estimate minus truth (m), sig_pos (E, 3) own σ; err_vel (E, 3);
    err_att (E, 3) roll/pitch/yaw estimate minus truth (rad, wrapped), sig_att (E, 3);
    nees_pos (E,) 3-dof, nees_pose (E,) 6-dof (NaN at epoch 0, the prior); lm_ids (L,),
    lm_err (L,) final 3-D landmark errors (m); nis, nis_dof; time_s of ``steps`` epochs.
    """

    name: str
    err_pos: Array
    sig_pos: Array
    err_vel: Array
    err_att: Array
    sig_att: Array
    nees_pos: Array
    nees_pose: Array
    lm_ids: Array
    lm_err: Array
    nis: Array
    nis_dof: Array
    time_s: float
    steps: int
    diverged: bool = False
    failure: str | None = None
    extra_time_s: float = 0.0


@dataclass(frozen=True)
class DroneTrack:
    """Run 0's full output of one estimator (for plots and trajectory files)."""

    name: str
    p: Array
    q: Array
    pose_cov: Array
    bias: Array
    landmark_ids: Array
    landmarks: Array
    landmark_cov: Array


def score(est: DroneEstimate, log: DroneLog) -> DroneScores:
    """Reduce an estimate to :class:`DroneScores` against the log's truth."""
    tp, tv, tq = log.truth[:, 0:3], log.truth[:, 3:6], log.truth[:, 6:10]
    E = log.n_epochs
    ok = np.all(np.isfinite(est.q), axis=1)
    err_pos = est.p - tp
    err_vel = est.v - tv
    err_att = np.full((E, 3), np.nan)
    err_rot = np.full((E, 3), np.nan)
    sig_att = np.full((E, 3), np.nan)
    C = est.pose_cov
    if ok.any():
        err_att[ok] = wrap_angle(q_to_euler_zyx(est.q[ok]) - q_to_euler_zyx(tq[ok]))
        err_rot[ok] = QUAT.local(est.q[ok], tq[ok])
        J = euler_error_jacobian(est.q[ok], q_to_euler_zyx)
        with np.errstate(invalid="ignore"):
            Ce = J @ C[ok, 3:, 3:] @ np.swapaxes(J, -1, -2)
            sig_att[ok] = np.sqrt(np.clip(np.diagonal(Ce, axis1=1, axis2=2), 0.0, None))
    with np.errstate(invalid="ignore"):
        sig_pos = np.sqrt(np.clip(np.diagonal(C[:, :3, :3], axis1=1, axis2=2), 0.0, None))
    nees_pos = nees_series(-err_pos, C[:, :3, :3])
    nees_pose = nees_series(np.hstack([-err_pos, err_rot]), C)
    nees_pos[0] = nees_pose[0] = np.nan  # epoch 0 is the prior, not an estimate
    known = est.landmark_ids >= 0
    lm_err = np.linalg.norm(est.landmarks[known] - log.landmarks[est.landmark_ids[known]],
                            axis=1) if known.any() else np.zeros(0)
    return DroneScores(est.name, err_pos, sig_pos, err_vel, err_att, sig_att, nees_pos,
                       nees_pose, est.landmark_ids[known], lm_err, est.nis, est.nis_dof,
                       est.time_s, est.steps, est.diverged, est.failure, est.extra_time_s)


def track_of(est: DroneEstimate) -> DroneTrack:
    return DroneTrack(est.name, est.p, est.q, est.pose_cov, est.bias, est.landmark_ids,
                      est.landmarks, est.landmark_cov)


# --------------------------------------------------------------------------- one run

def run_once(world, run: int, seed_seq: np.random.SeedSequence, filters: Sequence[str],
             keep_tracks: bool = False, reference: bool = True) -> RunOutcome:
    """Simulate run ``run`` from its own seed; score every filter, the IMU-only baseline
    and (``reference``) the GTSAM smoother on the same log.

    ``RunOutcome.scores`` holds :class:`DroneScores`; with ``keep_tracks`` the tracks are
    :class:`DroneTrack`, ``truth`` is (E, 16) ``[p, v, q, b_g, b_a]``, ``true_landmarks``
    (N, 3) and ``times`` the epochs (s).
    """
    fs = world.filters
    if fs.mode != "joint":
        raise ValueError(f"drone-slam worlds run joint mode only (sigma points over the whole "
                         f"state), not {fs.mode!r}")
    rng = np.random.default_rng(seed_seq)
    log = simulate_drone(world, rng)
    ests = [run_drone_filter(log, name, association=fs.association,
                             gates=(fs.gate_accept, fs.gate_new), diverge_m=fs.divergence_m,
                             imu_noise_scale=fs.imu_noise_scale,
                             sensor_noise_scale=fs.sensor_noise_scale) for name in filters]
    ests.append(imu_only(log, fs.imu_noise_scale))
    if reference:
        from slam.kinds.drone.reference import smooth_drone

        ests.append(smooth_drone(log, imu_noise_scale=fs.imu_noise_scale,
                                 sensor_noise_scale=fs.sensor_noise_scale))
    scores = {e.name: score(e, log) for e in ests}
    tracks = {e.name: track_of(e) for e in ests} if keep_tracks else {}
    return RunOutcome(run, scores, tracks,  # type: ignore[arg-type]
                      log.truth if keep_tracks else None,
                      log.landmarks if keep_tracks else None,
                      log.times if keep_tracks else None)


# --------------------------------------------------------------------------- summary

def _loop_masks(times: Array, loop_end_times: Sequence[float]) -> list[Array]:
    out, start = [], -np.inf
    for end in loop_end_times:
        out.append((times > start) & (times <= end + 1e-9))
        start = end
    return out


def summarize_scores(scores: list[DroneScores], times: Array | None = None,
                     loop_end_times: Sequence[float] = ()) -> dict[str, Any]:
    """Monte Carlo summary of one estimator (a ``summary.json`` entry).

    Diverged runs are counted and left out of every statistic.
    """
    good = [s for s in scores if not s.diverged]
    out: dict[str, Any] = {"runs_scored": len(good), "diverged_runs": len(scores) - len(good)}
    if len(good) < len(scores):
        out["failures"] = sorted({s.failure or "" for s in scores if s.diverged})
    if not good:
        return out
    ep = np.stack([s.err_pos for s in good])  # (R, E, 3)
    out["pos_rmse_m"] = float(np.sqrt(np.nanmean(np.sum(ep**2, axis=2))))
    out["pos_rmse_xy_m"] = float(np.sqrt(np.nanmean(np.sum(ep[..., :2] ** 2, axis=2))))
    out["pos_err_range_m"] = {a: [float(np.nanmin(ep[..., i])), float(np.nanmax(ep[..., i]))]
                              for i, a in enumerate(AXES)}
    out["pos_rmse_axis_m"] = {a: float(np.sqrt(np.nanmean(ep[..., i] ** 2)))
                              for i, a in enumerate(AXES)}
    ev = np.stack([s.err_vel for s in good])
    out["vel_rmse_mps"] = float(np.sqrt(np.nanmean(np.sum(ev**2, axis=2))))
    ea = np.stack([s.err_att for s in good])
    out["att_rmse_deg"] = {a: float(np.degrees(np.sqrt(np.nanmean(ea[..., i] ** 2))))
                           for i, a in enumerate(ATT_AXES)}
    out["heading_rmse_deg"] = out["att_rmse_deg"]["yaw"]
    if times is not None and len(loop_end_times) > 1:
        norm = np.linalg.norm(ep, axis=2)
        loops = _loop_masks(np.asarray(times), loop_end_times)
        out["loop_pos_rmse_m"] = [float(np.sqrt(np.nanmean(norm[:, m] ** 2))) for m in loops]
        out["loop_pos_max_err_m"] = [float(np.nanmax(norm[:, m])) for m in loops]
    lm = np.concatenate([s.lm_err for s in good])
    if lm.size:
        out["landmark_rmse_m"] = float(np.sqrt(np.mean(lm**2)))
        out["landmarks_mapped_mean"] = float(np.mean([len(s.lm_err) for s in good]))
    pos = anees_stats(np.stack([s.nees_pos for s in good]), 3)
    if pos:
        out["anees"] = pos["value"]
        out["anees_dof"] = 3
        out["anees_bounds_95"] = pos["band"]
        out["anees_steps_inside_95"] = pos["inside"]
        out["anees_distance_to_band"] = pos["distance"]
    pose = anees_stats(np.stack([s.nees_pose for s in good]), 6)
    if pose:
        out["anees_pose6"] = pose["value"]
        out["anees_pose6_bounds_95"] = pose["band"]
        out["anees_pose6_steps_inside_95"] = pose["inside"]
    out.update(nis_and_timing(good))
    return out


def summarize_drone(world, outcomes: list[RunOutcome], filters: list[str], runs: int,
                    seed: int) -> dict:
    """The ``summary.json`` dict of a drone SINS/SLAM campaign."""
    traj, _ = truth_of(world)
    n = world.samples_per_epoch
    times = np.arange(traj.n_samples // n + 1) * n * traj.dt
    loops = (traj.loop_end_steps * traj.dt).tolist()

    def entry(name: str) -> dict[str, Any]:
        return summarize_scores([o.scores[name] for o in outcomes if name in o.scores],
                                times, loops)

    out: dict[str, Any] = {
        "world": world.name,
        "kind": world.kind,
        "runs": runs,
        "seed": seed,
        "filters": {n_: entry(n_) for n_ in filters},
        "filter_descriptions": {n_: FILTER_DESCRIPTIONS.get(n_, n_) for n_ in filters},
        "baselines": {IMU_ONLY: entry(IMU_ONLY)},
    }
    if any(REFERENCE in o.scores for o in outcomes):
        ref = entry(REFERENCE)
        good = [o.scores[REFERENCE] for o in outcomes
                if REFERENCE in o.scores and not o.scores[REFERENCE].diverged]
        for key in ("time_per_step_s", "time_per_run_s"):
            ref.pop(key, None)
        if good:
            ref["time_s"] = float(np.mean([s.time_s for s in good]))
            ref["marginals_time_s"] = float(np.mean([s.extra_time_s for s in good]))
        out["reference"] = {REFERENCE: ref}
        ref_lm = ref.get("landmark_rmse_m")
        if ref_lm:
            for name in filters:
                f = out["filters"][name]
                if "landmark_rmse_m" in f:
                    f["landmark_rmse_vs_gtsam"] = f["landmark_rmse_m"] / ref_lm
    out["flight"] = {
        "duration_s": float(times[-1]),
        "epochs": int(len(times)),
        "loop_end_times_s": loops,
        "speed_mps": world.vehicle.speed_mps,
        "height_above_ground_m": world.vehicle.height_above_ground_m,
        "terrain": world.terrain.kind,
        "imu_rate_hz": world.imu.rate_hz,
        "sensor_rate_hz": world.sensor.rate_hz,
    }
    out["conventions"] = {
        "frames": "ENU navigation frame, forward-left-up body frame, q_nb Hamilton",
        "euler": "Z-Y-X (yaw about z, then pitch about y, then roll about x); "
                 "pitch positive nose-down in forward-left-up",
        "anees": "headline anees is the 3-dof position NEES / 3; anees_pose6 the 6-dof "
                 "[position, body-frame attitude] NEES / 6",
        "mechanisation": "flat-Earth local-level ENU, gravity constant, Earth rate "
                         + ("on" if world.imu.earth_rate else "off"),
    }
    out["paper"] = world.paper
    return out
