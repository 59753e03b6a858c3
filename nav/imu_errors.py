r"""IMU sensor errors: constant bias, bias random walk and white noise per axis.

:func:`corrupt_imu` adds them to error-free readings: per axis a constant bias drawn from
:math:`N(0, \sigma_b^2)`, a bias random walk (:math:`\sigma_{rw}\sqrt{\Delta t}` per sample)
and white noise (:math:`\sigma_{wn}/\sqrt{\Delta t}` per sample).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

__all__ = ["ImuErrors", "ImuLog", "corrupt_imu", "first_order_markov"]


@dataclass(frozen=True)
class ImuErrors:
    """IMU error model (SI; densities per √s) - see :class:`slam.kinds.drone.world.ImuSpec`."""

    gyro_bias_sigma: float
    gyro_bias_rw: float
    gyro_arw: float
    accel_bias_sigma: float
    accel_bias_rw: float
    accel_vrw: float


@dataclass(frozen=True)
class ImuLog:
    """Measured IMU samples (K, 3) and the true biases (K + 1, 3) at every sample
    (reading ``k`` carries ``bias[k]``)."""

    gyro: Array
    accel: Array
    bias_gyro: Array
    bias_accel: Array


def corrupt_imu(gyro: Array, accel: Array, dt: float, errors: ImuErrors,
                rng: np.random.Generator, scale: float = 1.0) -> ImuLog:
    """Add biases, bias random walks and white noise to error-free readings.

    Draw order (fixed, for reproducibility): gyro bias, accel bias, gyro bias walk, accel
    bias walk, gyro white noise, accel white noise.  ``scale`` multiplies every sigma
    (``0``: an error-free log).
    """
    K = gyro.shape[0]
    e = errors
    bg0 = rng.standard_normal(3) * (scale * e.gyro_bias_sigma)
    ba0 = rng.standard_normal(3) * (scale * e.accel_bias_sigma)
    sq = math.sqrt(dt)
    wg = rng.standard_normal((K, 3)) * (scale * e.gyro_bias_rw * sq)
    wa = rng.standard_normal((K, 3)) * (scale * e.accel_bias_rw * sq)
    ng = rng.standard_normal((K, 3)) * (scale * e.gyro_arw / sq)
    na = rng.standard_normal((K, 3)) * (scale * e.accel_vrw / sq)
    bg = bg0 + np.vstack([np.zeros(3), np.cumsum(wg, axis=0)])
    ba = ba0 + np.vstack([np.zeros(3), np.cumsum(wa, axis=0)])
    return ImuLog(gyro + bg[:-1] + ng, accel + ba[:-1] + na, bg, ba)


def first_order_markov(start: Array, drive: Array, phi: float) -> Array:
    r"""(K + 1, ...) first-order Markov series :math:`y_0` = ``start``,
    :math:`y_k = φ\,y_{k-1} + d_{k-1}` for the drive ``d`` (K, ...), in one linear filter."""
    from scipy.signal import lfilter  # here: scipy.signal loads scipy.stats (~1 s)

    start = np.asarray(start, dtype=np.float64)
    y, _ = lfilter([1.0], [1.0, -phi], drive, axis=0, zi=(phi * start)[None])
    return np.vstack([start, y])
