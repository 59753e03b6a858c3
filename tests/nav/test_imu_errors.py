"""IMU error model (:mod:`nav.imu_errors`): noise statistics and the zero scale."""

from __future__ import annotations

import math

import numpy as np

from nav.imu_errors import ImuErrors, corrupt_imu


def test_corrupt_imu_statistics_and_zero_scale():
    rng = np.random.default_rng(5)
    K, dt = 200_000, 0.01
    z = np.zeros((K, 3))
    e = ImuErrors(1e-3, 0.0, 2e-3, 0.02, 0.0, 3e-3)
    log = corrupt_imu(z, z, dt, e, rng)
    noise = log.gyro - log.bias_gyro[:-1]
    assert np.allclose(np.std(noise, axis=0), 2e-3 / math.sqrt(dt), rtol=0.02)
    assert np.allclose(log.bias_gyro, log.bias_gyro[0])  # no random walk asked for
    clean = corrupt_imu(z, z, dt, e, rng, scale=0.0)
    assert not np.any(clean.gyro) and not np.any(clean.accel)
