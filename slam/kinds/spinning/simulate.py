r"""The sensor log of one spinning-projectile run: truth, gyro and magnetometer
([Spin SR-CH∞KF] §2, §5).

Epochs :math:`t_k = k\,\Delta t` (Δt = 0.1 s, Table 2) from launch to the last epoch
before impact.  At every epoch:

* **magnetometer** (three axes, body frame, nT): :math:`\tilde b_k = b(\alpha_k,
  \beta_k, \gamma_k) + v_k` (eq. 6), :math:`v_k = f_m \sigma_m \epsilon` per axis
  (:mod:`slam.kinds.spinning.noise`);
* **gyro** over :math:`[t_k, t_{k+1}]`: the pitch and yaw rates
  :math:`u_k = [(\alpha_{k+1}-\alpha_k)/\Delta t,\ (\beta_{k+1}-\beta_k)/\Delta t] + n_k`,
  :math:`n_k = f_g (\sigma_g/\sqrt{\Delta t})\,\epsilon` with :math:`\sigma_g` the rate
  noise density, and the roll channel :math:`\omega_x` clipped at its range (the paper's
  saturated, "open circuit" axis; logged, never used).

The gyro output is taken as already resolved into pitch and yaw rates (eq. 2): resolving
the two spinning transverse channels needs the roll at a rate far above the spin, which
the sensor package does internally; its resolution error is not modelled.  The mean rates
over each interval are exact, so ``X_k = X_{k-1} + Δt u_{k-1}`` (eq. 9) reproduces the
truth to round-off on a noise-free log.

Draw order (fixed, whatever the noise levels and shape): gyro noise, magnetometer noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.arrays import read_only
from slam.kinds.spinning.noise import NoiseShape, unit_noise
from slam.kinds.spinning.truth import Field, FlightSpec, attitude_at, body_field, trajectory

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SimConfig:
    """What one simulation needs (SI units, radians, nT).

    ``gyro_sigma_rad_s_sqrt_hz`` and ``mag_sigma_nt`` are the *assumed* noises; the true
    ones are ``noise.gyro_factor`` and ``noise.magnetometer_factor`` times them.
    """

    dt_s: float
    flight: FlightSpec
    roll0_rad: float
    spin_rev_s: float
    spin_decay_s: float
    field: Field
    gyro_sigma_rad_s_sqrt_hz: float
    roll_range_rad_s: float
    mag_sigma_nt: float
    noise: NoiseShape

    def with_noise(self, **changes: Any) -> SimConfig:
        """This configuration with :class:`NoiseShape` fields replaced."""
        return replace(self, noise=replace(self.noise, **changes))


@dataclass(frozen=True, eq=False)
class SpinLog:
    """One run's log (read-only arrays; E epochs).

    times (E,); alpha, beta, gamma (E,) true pitch, yaw, roll (rad; roll in [0, 2π));
    gyro (E - 1, 2) measured pitch and yaw rates over each interval (rad/s);
    gyro_roll (E - 1,) the saturated roll channel (rad/s); mag (E, 3) measured body field
    (nT); mag_true (E, 3) the noise-free field; metadata: the flight's numbers.
    """

    dt: float
    times: Array
    alpha: Array
    beta: Array
    gamma: Array
    gyro: Array
    gyro_roll: Array
    mag: Array
    mag_true: Array
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def n_epochs(self) -> int:
        return len(self.times)

    @property
    def truth(self) -> Array:
        """(E, 2) true ``[pitch, yaw]``."""
        return np.column_stack([self.alpha, self.beta])


def sim_config(world: Any) -> SimConfig:
    """The simulation settings of a ``spinning`` world
    (:class:`~slam.kinds.spinning.world.SpinningWorld`)."""
    return SimConfig(dt_s=world.sample_interval_s, flight=world.flight,
                     roll0_rad=world.roll0_rad, spin_rev_s=world.spin.rate_rev_s,
                     spin_decay_s=world.spin.decay_time_s, field=world.field,
                     gyro_sigma_rad_s_sqrt_hz=world.gyro.rate_noise_rad_s_sqrt_hz,
                     roll_range_rad_s=world.gyro.roll_range_rad_s,
                     mag_sigma_nt=world.magnetometer.noise_nt, noise=world.truth_noise)


def epochs(cfg: SimConfig) -> Array:
    """The epochs from launch to the last one before impact."""
    flight = trajectory(cfg.flight)
    n = int(math.floor(flight.flight_time_s / cfg.dt_s + 1e-9))
    return np.arange(n + 1) * cfg.dt_s


def simulate(cfg: SimConfig, rng: np.random.Generator) -> SpinLog:
    """Simulate one run (module docstring)."""
    flight = trajectory(cfg.flight)
    t = epochs(cfg)
    tr = attitude_at(flight, t, cfg.spin_rev_s, cfg.spin_decay_s, cfg.roll0_rad)
    E = len(t)
    ns = cfg.noise
    gyro_noise = unit_noise(rng, (E - 1, 2), ns)
    mag_noise = unit_noise(rng, (E, 3), ns)
    sigma_rate = cfg.gyro_sigma_rad_s_sqrt_hz / math.sqrt(cfg.dt_s)
    rates = np.column_stack([tr.alpha_rate, tr.beta_rate])
    gyro = rates + ns.gyro_factor * sigma_rate * gyro_noise
    # body roll rate: omega_x = gamma_dot + beta_dot sin(alpha) (see truth), clipped
    omega_x = tr.roll_rate[:-1] + tr.beta_rate * np.sin(tr.alpha[:-1])
    gyro_roll = np.clip(omega_x, -cfg.roll_range_rad_s, cfg.roll_range_rad_s)
    b = body_field(cfg.field, tr.alpha, tr.beta, tr.gamma)
    mag = b + ns.magnetometer_factor * cfg.mag_sigma_nt * mag_noise
    meta = {"drag_k_per_m": flight.k_per_m, "flight_time_s": flight.flight_time_s,
            "range_m": flight.range_m, "apex_m": flight.apex_m,
            "noise": ns.distribution, "magnetometer_factor": ns.magnetometer_factor,
            "gyro_factor": ns.gyro_factor}
    arrays = (t, tr.alpha, tr.beta, tr.gamma, gyro, gyro_roll, mag, b)
    return SpinLog(cfg.dt_s, *(read_only(a, np.float64) for a in arrays), meta)
