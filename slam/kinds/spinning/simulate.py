r"""The sensor log of one spinning-projectile run: truth, gyro and magnetometer
([Spin SR-CH∞KF] §2, §5).

Epochs :math:`t_k = k\,\Delta t` (Δt = 0.1 s, Table 2) from launch to the last epoch
before impact.  At every epoch:

* **magnetometer** (three axes, body frame, nT): :math:`\tilde b_k = b(\alpha_k,
  \beta_k, \gamma_k) + v_k` (eq. 6), :math:`v_k = f_m \sigma_m \epsilon` per axis
  (:mod:`slam.kinds.spinning.noise`);
* **gyro** at :math:`t_k` (:mod:`slam.kinds.spinning.gyro`): the two transverse body
  rates :math:`\omega_k = [\omega_y, \omega_z]` of the pitch and yaw rates over
  :math:`[t_k, t_{k+1}]`, turned by the true roll :math:`\gamma_k` (eq. 1 inverted), plus
  :math:`n_k = f_g (\sigma_g/\sqrt{\Delta t})\,\epsilon` per channel (:math:`\sigma_g` the
  rate noise density); the roll channel :math:`\omega_x` clipped at its range (the paper's
  saturated, "open circuit" axis; logged, never used).

The transverse samples spin with the body (15 rev/s against 10 Hz sampling): only the roll
at the same instant turns them back into pitch and yaw rates (eq. 3), and that roll comes
from the magnetometer.  Each sample is the body rate of the interval's *mean* pitch and yaw
rates at :math:`(\alpha_k, \gamma_k)`, so that eq. 3 with the true roll,
:math:`X_{k+1} = X_k + \Delta t\,\mathrm{resolve}(\omega_k, \alpha_k, \gamma_k)`,
reproduces the truth to round-off on a noise-free log: the one modelled error of the
resolution is the roll's.  (An instantaneous sample would add the rectangle rule's error,
about :math:`\Delta t^2|\ddot\alpha|/2` per step, well below the gyro noise.)

Draw order (fixed, whatever the noise levels and shape): gyro noise, magnetometer noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.arrays import read_only
from slam.kinds.spinning.gyro import body_rates
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
    gyro (E - 1, 2) measured transverse body rates [ω_y, ω_z] at the start of each
    interval (rad/s);
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
    # body rates at t_k of the interval's mean Euler rates, turned by the true roll (eq. 1)
    omega = body_rates(tr.alpha[:-1], tr.gamma[:-1], tr.alpha_rate, tr.beta_rate,
                       tr.roll_rate[:-1])
    gyro = omega[:, 1:] + ns.gyro_factor * sigma_rate * gyro_noise
    gyro_roll = np.clip(omega[:, 0], -cfg.roll_range_rad_s, cfg.roll_range_rad_s)
    b = body_field(cfg.field, tr.alpha, tr.beta, tr.gamma)
    mag = b + ns.magnetometer_factor * cfg.mag_sigma_nt * mag_noise
    meta = {"drag_k_per_m": flight.k_per_m, "flight_time_s": flight.flight_time_s,
            "range_m": flight.range_m, "apex_m": flight.apex_m,
            "noise": ns.distribution, "magnetometer_factor": ns.magnetometer_factor,
            "gyro_factor": ns.gyro_factor}
    arrays = (t, tr.alpha, tr.beta, tr.gamma, gyro, gyro_roll, mag, b)
    return SpinLog(cfg.dt_s, *(read_only(a, np.float64) for a in arrays), meta)
