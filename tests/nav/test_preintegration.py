"""nav.preintegration: the smoothers' combined-IMU preintegration parameters."""

from __future__ import annotations

import numpy as np
import pytest

from nav.preintegration import VAR_FLOOR, combined_params

pytest.importorskip("gtsam")


def test_variances_floor_gravity_and_earth_rate() -> None:
    p = combined_params(9.8, 1e-6, 0.0, 2e-8, 3e-8, earth_rate=[0.0, 1e-5, 2e-5])
    assert np.array_equal(p.getGyroscopeCovariance(), 1e-6 * np.eye(3))
    assert np.array_equal(p.getAccelerometerCovariance(), VAR_FLOOR * np.eye(3))
    assert np.array_equal(p.getIntegrationCovariance(), 1e-12 * np.eye(3))
    assert np.array_equal(p.getBiasOmegaCovariance(), 2e-8 * np.eye(3))
    assert np.array_equal(p.getBiasAccCovariance(), 3e-8 * np.eye(3))
    assert np.array_equal(p.n_gravity, [0.0, 0.0, -9.8])
    assert np.array_equal(p.getOmegaCoriolis(), [0.0, 1e-5, 2e-5])


def test_no_earth_rate_and_own_floor() -> None:
    p = combined_params(9.8, 0.0, 0.0, 0.0, 0.0, integration_var=1e-10, floor=1e-24)
    assert p.getOmegaCoriolis() is None
    assert np.array_equal(p.getGyroscopeCovariance(), 1e-24 * np.eye(3))
    assert np.array_equal(p.getIntegrationCovariance(), 1e-10 * np.eye(3))
