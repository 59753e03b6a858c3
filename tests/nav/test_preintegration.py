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


@pytest.mark.parametrize("rate", [0.003, 1.5])  # the Taylor branch, the closed form
def test_batched_rotation_preintegration_equals_gtsams(rate: float) -> None:
    """preintegrate_rotation against ``integrateMeasurement`` per sample: ΔR, Σ, ΔT, and
    the factor's error and Jacobians at a nonzero bias (so ∂ΔR/∂b too)."""
    import gtsam

    from nav.preintegration import preintegrate_rotation

    rng = np.random.default_rng(4)
    dt, var = 0.02, 3e-7
    gyro = rng.normal(0.0, rate, (4, 25, 3))
    T, dR, dR_db, cov = preintegrate_rotation(gyro, dt, var)
    params = gtsam.PreintegratedRotationParams()
    params.setGyroscopeCovariance(var * np.eye(3))
    values = gtsam.Values()
    values.insert(1, gtsam.Rot3.Expmap(rng.normal(size=3)))
    values.insert(2, gtsam.Rot3.Expmap(rng.normal(size=3)))
    values.insert(3, rng.normal(0.0, 0.05, 3))
    for i in range(len(gyro)):
        pim = gtsam.PreintegratedAhrsMeasurements(params, np.zeros(3))
        for w in gyro[i]:
            pim.integrateMeasurement(w, dt)
        ours = gtsam.PreintegratedAhrsMeasurements(params, np.zeros(3), T, gtsam.Rot3(dR[i]),
                                                   dR_db[i], cov[i])
        assert T == pim.deltaTij()
        np.testing.assert_allclose(dR[i], pim.deltaRij().matrix(), rtol=0, atol=2e-15)
        c = pim.preintMeasCov()
        np.testing.assert_allclose(cov[i], c, rtol=0, atol=1e-13 * np.abs(c).max())
        a, b = gtsam.AHRSFactor(1, 2, 3, pim), gtsam.AHRSFactor(1, 2, 3, ours)
        np.testing.assert_allclose(b.unwhitenedError(values), a.unwhitenedError(values),
                                   rtol=1e-12, atol=1e-15)
        ja, jb = a.linearize(values).jacobian()[0], b.linearize(values).jacobian()[0]
        np.testing.assert_allclose(jb, ja, rtol=0, atol=1e-12 * np.abs(ja).max())
