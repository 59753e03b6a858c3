"""The drone's filter models (:mod:`slam.kinds.drone.models`): analytic Jacobians against
numerical ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators.linearise import numerical_jacobian
from slam.kinds.drone import models as dm


def _state(n_lm: int, rng: np.random.Generator) -> np.ndarray:
    from nav.quaternion import qexp

    x = np.concatenate([rng.normal(size=3) * 5, rng.normal(size=3), qexp(rng.normal(size=3)),
                        rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-2,
                        rng.normal(size=3 * n_lm) * 10 + 20])
    return x


def test_measurement_and_augmentation_jacobians_match_numerical():
    rng = np.random.default_rng(4)
    x = _state(3, rng)
    space = dm.state_space(3)
    slots = np.array([2, 0])
    meas = dm.observation_model(slots, np.eye(3))
    J, _ = numerical_jacobian(lambda X, W: meas.h(X), x, space, meas.space)
    assert np.allclose(meas.jacobian(x), J, atol=1e-6)
    z = dm.rae(x[None], slots)[0]
    aug = dm.augmentation_model(3, z, np.eye(6) * 0.01)
    Jn, y = numerical_jacobian(lambda X, W: aug.f(X, z, W), x, space, aug.space, nw=6)
    F, G = aug.jacobian(x, z)
    assert np.allclose(np.hstack([F, G]), Jn, atol=1e-6)
    # inverse observation of the observation gives the landmarks back
    assert np.allclose(y[-6:], x[dm.VEH_AMBIENT:][np.r_[6:9, 0:3]], atol=1e-9)


def test_transition_jacobian_close_to_numerical():
    rng = np.random.default_rng(7)
    x = _state(1, rng)
    gyro = rng.normal(size=(20, 3)) * 0.3
    acc = rng.normal(size=(20, 3)) + [0.0, 0.0, 9.8]
    nav = dm.NavFrame(0.01, np.array([0.0, 0.0, -9.80665]))
    noise = dm.ImuNoise(1e-4, 1e-3, 1e-6, 1e-5)
    model = dm.imu_transition(x, 1, gyro, acc, nav, noise)
    space = dm.state_space(1)
    Jn, y = numerical_jacobian(lambda X, W: model.f(X, (gyro, acc)), x, space, space)
    F = model.jacobian(x, (gyro, acc))
    assert np.max(np.abs(F - Jn)) < 2e-3 * np.max(np.abs(Jn))
    assert np.allclose(model.noise.sqrt @ model.noise.sqrt.T, model.noise.cov, atol=1e-15)
    # position variance of white accelerometer noise over T = 0.2 s: sigma^2 T^3 / 3
    assert model.noise.cov[0, 0] == pytest.approx(1e-6 * 0.2**3 / 3, rel=0.05)
