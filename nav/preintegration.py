"""GTSAM's combined IMU preintegration parameters from the IMU's per-axis variances: the
IMU model of the smoothers that serve as references (gtsam is imported on first use)."""

from __future__ import annotations

from typing import Any

import numpy as np

VAR_FLOOR = 1e-20
"""Variance floor of the densities (keeps a zero random walk finite)."""


def combined_params(gravity: float, gyro_var: float, accel_var: float, gyro_bias_var: float,
                    accel_bias_var: float, *, earth_rate: Any = None,
                    integration_var: float = 1e-12, floor: float = VAR_FLOOR) -> Any:
    """``gtsam.PreintegrationCombinedParams`` for gravity ``gravity`` (m/s², along -z):
    the gyro and accelerometer white-noise and bias random-walk variances per axis (each at
    least ``floor``), the integration variance, and the Earth rate (None: none)."""
    import gtsam

    p = gtsam.PreintegrationCombinedParams.MakeSharedU(gravity)
    eye = np.eye(3)
    p.setGyroscopeCovariance(max(gyro_var, floor) * eye)
    p.setAccelerometerCovariance(max(accel_var, floor) * eye)
    p.setIntegrationCovariance(integration_var * eye)
    p.setBiasOmegaCovariance(max(gyro_bias_var, floor) * eye)
    p.setBiasAccCovariance(max(accel_bias_var, floor) * eye)
    if earth_rate is not None:
        p.setOmegaCoriolis(np.asarray(earth_rate, dtype=float))
    return p
