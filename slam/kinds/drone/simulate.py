"""One run's drone log: IMU errors, landmark observations (range, azimuth, elevation;
field of view, range and terrain occlusion) and the filters' initial state."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from estimators import wrap_angle
from estimators.linalg import Array
from nav.imu_errors import ImuErrors, corrupt_imu
from nav.quaternion import qconj, qexp, qmul, qrotate
from slam.kinds.drone.models import (
    VEH_DIM,
    ImuNoise,
    NavFrame,
    rae_of,
)
from slam.kinds.drone.truth import nav_frame, terrain_of, truth_of

if TYPE_CHECKING:
    from nav.terrain import Terrain

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


