r"""IMU noise: datasheet units to continuous PSDs, and the bias processes.

Datasheet units (:func:`datasheet_psd`)
---------------------------------------
=============================  ======================  ================================
datasheet figure               unit                    continuous density (SI)
=============================  ======================  ================================
angle random walk (ARW)        °/√h                    ``ARW·(π/180)/60``  rad/s/√Hz
velocity random walk (VRW)     m/s/√h                  ``VRW/60``          m/s²/√Hz
gyro bias instability          °/h                     ``BI·(π/180)/3600`` rad/s (σ)
accel bias instability         mg                      ``BI·g0/1000``      m/s² (σ)
gyro rate random walk (RRW)    °/h/√h                  ``RRW·(π/180)/3600/60`` rad/s/√s
accel random walk              m/s²/√h                 ``K/60``            m/s²/√s
=============================  ======================  ================================

(:math:`1\,\mathrm{h} = 3600\,\mathrm{s}`, :math:`\sqrt{1\,\mathrm{h}} = 60\sqrt{\mathrm{s}}`.)
The white-noise PSDs are the squares of the densities: a sample averaged over Δt has
:math:`\sigma = N/\sqrt{\Delta t}`.  The bias instability (the flat floor of the Allan
deviation) is modelled as a first-order Gauss-Markov bias of steady-state σ equal to the
figure with the stated correlation time :math:`T` (driving PSD :math:`2\sigma^2/T`); a
rate random walk is a random-walk bias of PSD :math:`K^2`.  Both may be given; their
variances add in the discrete model.

Bias processes (:class:`BiasProcess`)
-------------------------------------
:math:`\dot b = -b/T + w`, :math:`E[w w] = q_m = 2\sigma_m^2/T`, plus a random walk of PSD
:math:`q_r`.  Over :math:`\Delta t`: :math:`b' = \phi b + w_d`,
:math:`\phi = e^{-\Delta t/T}` (1 for :math:`T = \infty`) and
:math:`\mathrm{Var}\,w_d = \sigma_m^2(1 - \phi^2) + q_r\Delta t` (exact for the Markov part;
exact for the walk when :math:`T = \infty`, to first order in :math:`\Delta t/T` otherwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from nav.strapdown import G0

DEG = math.pi / 180.0
SQRT_HOUR = 60.0

__all__ = ["BiasProcess", "ImuPsd", "datasheet_psd", "per_sample_density"]


@dataclass(frozen=True)
class BiasProcess:
    """One sensor's bias per axis: a first-order Markov part (steady-state ``markov_sigma``,
    correlation time ``time_s``; ``inf`` or a zero σ: none) plus a random walk of PSD
    ``walk_psd`` (units²/s)."""

    markov_sigma: float = 0.0
    time_s: float = math.inf
    walk_psd: float = 0.0

    def decay(self, dt: float) -> float:
        r""":math:`\phi = e^{-\Delta t/T}` (1 for a pure random walk)."""
        if self.markov_sigma == 0.0 or math.isinf(self.time_s):
            return 1.0
        return math.exp(-dt / self.time_s)

    def rate(self) -> float:
        """The drift-back rate ``1/T`` of the error equation (0 for a random walk)."""
        if self.markov_sigma == 0.0 or math.isinf(self.time_s):
            return 0.0
        return 1.0 / self.time_s

    def psd(self) -> float:
        r"""The continuous driving PSD :math:`2\sigma_m^2/T + q_r`."""
        return 2.0 * self.markov_sigma**2 * self.rate() + self.walk_psd

    def discrete_variance(self, dt: float) -> float:
        """Variance added per axis over ``dt`` (module docstring)."""
        phi = self.decay(dt)
        markov = self.markov_sigma**2 * (1.0 - phi * phi) if phi < 1.0 else 0.0
        return markov + self.walk_psd * dt

    def steady_sigma(self) -> float:
        """The stationary σ (``inf`` with a random walk)."""
        return math.inf if self.walk_psd > 0.0 else self.markov_sigma


@dataclass(frozen=True)
class ImuPsd:
    """Continuous-time IMU noise (SI): white-noise densities (per √Hz) and the bias
    processes of the gyro and the accelerometer."""

    gyro_density: float
    accel_density: float
    gyro_bias: BiasProcess
    accel_bias: BiasProcess

    def as_dict(self) -> dict[str, float | str]:
        """The figures for a summary (SI, densities per √Hz, PSDs per s)."""
        g, a = self.gyro_bias, self.accel_bias

        def time(t: float) -> float | str:
            return t if math.isfinite(t) else "inf"

        return {"gyro_density_rad_s_sqrt_hz": self.gyro_density,
                "accel_density_mps2_sqrt_hz": self.accel_density,
                "gyro_bias_markov_sigma_rad_s": g.markov_sigma, "gyro_bias_time_s": time(g.time_s),
                "gyro_bias_walk_psd": g.walk_psd,
                "accel_bias_markov_sigma_mps2": a.markov_sigma, "accel_bias_time_s": time(a.time_s),
                "accel_bias_walk_psd": a.walk_psd}


def datasheet_psd(arw_deg_sqrt_h: float, vrw_mps_sqrt_h: float, *,
                  gyro_bias_instability_deg_h: float = 0.0,
                  gyro_bias_time_s: float = math.inf,
                  gyro_rate_random_walk_deg_h_sqrt_h: float = 0.0,
                  accel_bias_instability_mg: float = 0.0,
                  accel_bias_time_s: float = math.inf,
                  accel_random_walk_mps2_sqrt_h: float = 0.0) -> ImuPsd:
    """Datasheet figures -> :class:`ImuPsd` (the conversion table of the module docstring)."""
    gyro = BiasProcess(gyro_bias_instability_deg_h * DEG / 3600.0, gyro_bias_time_s,
                       (gyro_rate_random_walk_deg_h_sqrt_h * DEG / 3600.0 / SQRT_HOUR) ** 2)
    accel = BiasProcess(accel_bias_instability_mg * G0 / 1000.0, accel_bias_time_s,
                        (accel_random_walk_mps2_sqrt_h / SQRT_HOUR) ** 2)
    return ImuPsd(arw_deg_sqrt_h * DEG / SQRT_HOUR, vrw_mps_sqrt_h / SQRT_HOUR, gyro, accel)


def per_sample_density(sigma_per_sample: float, dt: float) -> float:
    r"""A random-walk step σ per sample of period ``dt`` as a density per √s,
    :math:`\sigma/\sqrt{\Delta t}` (``n`` samples add :math:`\sqrt n\,\sigma`)."""
    return sigma_per_sample / math.sqrt(dt)
