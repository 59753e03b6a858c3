r"""Fixed-wing sensors on the truth flight: a seeded, lossless log.

IMU (``rate_hz``): the error-free readings of :func:`slam.kinds.fixed_wing.flight.fly` plus

.. math::

    \tilde\omega_k = \omega_k + \varepsilon_c + \varepsilon_{m,k} + n_{g,k},\qquad
    \tilde f_k = f_k + \nabla_{m,k} + n_{a,k},

the constant gyro drift :math:`\varepsilon_c \sim N(0, \sigma_c^2)`, first-order Markov
drifts ([Fixed-wing EA-UKF] eq. 18) :math:`\varepsilon_{m,k+1} = \phi_a \varepsilon_{m,k} + w`,
:math:`\phi_a = e^{-\Delta t/T_a}`, :math:`\mathrm{var}\,w = q_g^2 T_a (1 - \phi_a^2)/2`
(exact discretisation of :math:`\dot\varepsilon = -\varepsilon/T_a + w_1`, density
:math:`q_g`), starting at 0; :math:`\nabla_m` likewise with :math:`T_b, q_a`, starting
from :math:`N(0, \sigma_a^2)`; white noise :math:`\sigma/\sqrt{\Delta t}` per sample.

Magnetometer at the EA epochs (every ``imu.rate_hz / ea.update_rate_hz`` samples):
:math:`m_b = C(q)^\top m^n + n_m`, :math:`m^n = F[\cos I \sin D, \cos I \cos D, -\sin I]`
(ENU; declination D east of north, inclination I downwards).

GNSS at ``gnss.rate_hz``: true position and velocity plus white noise (our reading of
the paper's unnamed aiding sensor).  ``scale = 0`` gives a noise-free log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from nav.imu_errors import first_order_markov
from nav.quaternion import qconj, qrotate
from nav.strapdown import earth_rate_enu, gravity_enu
from slam.kinds.fixed_wing.flight import Trajectory, fly
from slam.kinds.fixed_wing.world import FixedWingWorld, FlightSpec

Array = NDArray[np.float64]
#: Longest epoch (s) of the GNSS-aided estimators: with fixes further apart, their
#: prediction is cut into whole fractions of the GNSS period (:attr:`FixedWingLog.n_ins`).
INS_EPOCH_MAX_S = 1.0


@dataclass(frozen=True)
class FixedWingLog:
    """Truth and every sensor reading of one run.

    traj : the truth (every IMU sample); gyro, accel : (K, 3) readings;
    eps_c (3,), eps_m (K + 1, 3), nabla (K + 1, 3) : the true drifts (reading ``k``
    carries index ``k``); mag : (J, 3) body field at EA epoch ``j`` (sample ``j n_ea``);
    gnss_p, gnss_v : (G, 3) fixes at GNSS epoch ``i`` (sample ``i n_gnss``);
    gravity, earth_rate, field_n : the navigation-frame constants.
    """

    world: FixedWingWorld
    traj: Trajectory
    gyro: Array
    accel: Array
    eps_c: Array
    eps_m: Array
    nabla: Array
    mag: Array
    gnss_p: Array
    gnss_v: Array
    gravity: Array
    earth_rate: Array | None
    field_n: Array

    @property
    def dt(self) -> float:
        return self.traj.dt

    @property
    def n_ea(self) -> int:
        """IMU samples per EA epoch."""
        return round(self.world.imu.rate_hz / self.world.ea.update_rate_hz)

    @property
    def n_gnss(self) -> int:
        """IMU samples per GNSS epoch."""
        return round(self.world.imu.rate_hz / self.world.gnss.rate_hz)

    @property
    def n_ins(self) -> int:
        """IMU samples per epoch of the GNSS-aided estimators (the INS filters and the
        smoother): the GNSS period when fixes come at least every :data:`INS_EPOCH_MAX_S`;
        else the longest whole fraction of it not above that, so that they have an
        estimate, and a score, between fixes far apart (in turns that fall between them)."""
        return ins_samples(self.world)

    @property
    def ins_epochs(self) -> int:
        """Epochs of the GNSS-aided estimators (``n_ins`` samples apart, from t = 0)."""
        return self.traj.n_samples // self.n_ins + 1

    @property
    def fix_every(self) -> int:
        """INS epochs per GNSS fix (fix ``i`` is at INS epoch ``i · fix_every``)."""
        return self.n_gnss // self.n_ins


def ins_samples(world: FixedWingWorld) -> int:
    """:attr:`FixedWingLog.n_ins` of ``world``: the largest divisor of the GNSS period's
    IMU samples that spans at most :data:`INS_EPOCH_MAX_S`."""
    n = round(world.imu.rate_hz / world.gnss.rate_hz)
    most = max(1, math.floor(INS_EPOCH_MAX_S * world.imu.rate_hz + 1e-9))
    return max(b for b in range(1, min(n, most) + 1) if n % b == 0)


def field_enu(world: FixedWingWorld) -> Array:
    """The geomagnetic field in ENU (µT), module docstring."""
    m = world.magnetometer
    ci = math.cos(m.inclination_rad)
    return m.field_ut * np.array([ci * math.sin(m.declination_rad),
                                  ci * math.cos(m.declination_rad),
                                  -math.sin(m.inclination_rad)])


def nav_constants(world: FixedWingWorld) -> tuple[Array, Array | None]:
    """``(g^n, ω_ie^n or None)`` of the world."""
    wie = earth_rate_enu(world.site.latitude_rad) if world.imu.earth_rate else None
    return gravity_enu(), wie


@lru_cache(maxsize=4)
def _fly(spec: FlightSpec, duration_s: float, dt: float, height_m: float,
         wie: tuple[float, ...] | None) -> Trajectory:
    return fly(spec, duration_s, dt, height_m, gravity_enu(),
               None if wie is None else np.array(wie))


def truth_of(world: FixedWingWorld) -> Trajectory:
    """The world's truth flight (deterministic; cached per process)."""
    _, wie = nav_constants(world)
    return _fly(world.flight, world.duration_s, world.imu.dt_s, world.site.height_m,
                None if wie is None else tuple(map(float, wie)))


def markov(rng: np.random.Generator, start: Array, K: int, dt: float, T: float,
           density: float) -> Array:
    """(K + 1, 3) first-order Markov series from ``start`` (module docstring)."""
    phi = math.exp(-dt / T)
    w = rng.standard_normal((K, 3)) * (density * math.sqrt(0.5 * T * (1.0 - phi * phi)))
    return first_order_markov(start, w, phi)


def simulate(world: FixedWingWorld, rng: np.random.Generator, scale: float = 1.0
             ) -> FixedWingLog:
    """One run's log; draw order: drifts, IMU noise, magnetometer, GNSS."""
    traj = truth_of(world)
    imu, K, dt = world.imu, traj.n_samples, traj.dt
    g, wie = nav_constants(world)
    eps_c = rng.standard_normal(3) * (scale * imu.gyro_bias_sigma_rad_s)
    eps_m = markov(rng, np.zeros(3), K, dt, imu.gyro_drift_time_s,
                   scale * imu.gyro_drift_rw_rad_s_sqrt_s)
    nabla0 = rng.standard_normal(3) * (scale * imu.accel_drift_sigma_mps2)
    nabla = markov(rng, nabla0, K, dt, imu.accel_drift_time_s,
                   scale * imu.accel_drift_rw_mps2_sqrt_s)
    sq = math.sqrt(dt)
    ng = rng.standard_normal((K, 3)) * (scale * imu.gyro_arw_rad_sqrt_s / sq)
    na = rng.standard_normal((K, 3)) * (scale * imu.accel_vrw_mps_sqrt_s / sq)
    gyro = traj.gyro + eps_c + eps_m[:-1] + ng
    accel = traj.accel + nabla[:-1] + na
    n_ea = round(imu.rate_hz / world.ea.update_rate_hz)
    m_n = field_enu(world)
    q_ea = traj.q[::n_ea]
    mag = qrotate(qconj(q_ea), m_n) + rng.standard_normal(q_ea.shape[:-1] + (3,)) * (
        scale * world.magnetometer.sigma_ut)
    n_g = round(imu.rate_hz / world.gnss.rate_hz)
    gn = world.gnss
    p_sig = np.array([gn.horizontal_sigma_m, gn.horizontal_sigma_m, gn.vertical_sigma_m])
    P, Vv = traj.p[::n_g], traj.v[::n_g]
    gnss_p = P + rng.standard_normal(P.shape) * (scale * p_sig)
    gnss_v = Vv + rng.standard_normal(Vv.shape) * (scale * gn.velocity_sigma_mps)
    return FixedWingLog(world, traj, gyro, accel, eps_c, eps_m, nabla, mag, gnss_p, gnss_v,
                        g, wie, m_n)
