"""Recorded-log filter models (:mod:`slam.kinds.recorded.models`): analytic Jacobians
against numerical ones; the measurement inverts the augmentation.
"""

from __future__ import annotations

import numpy as np

from estimators.linearise import numerical_jacobian
from slam.kinds.planar.models import state_space
from slam.kinds.recorded.models import (
    odometry_model,
    point_augmentation_model,
    point_observation_model,
)


def test_analytic_jacobians_match_numerical():
    rng = np.random.default_rng(1)
    x = np.concatenate([[1.0, -2.0, 0.7], rng.normal(0, 5, 6)])
    space = state_space(3)
    u = np.array([[0.5, 0.02, 0.1], [0.7, -0.01, -0.2]])
    tr = odometry_model(np.tile(np.diag([0.01, 0.002, 0.002]), (2, 1, 1)))
    F, G = tr.jacobian(x, u)
    J, _ = numerical_jacobian(lambda X, W: tr.f(X, u, W), x, space, space, 6, 1e-7)
    np.testing.assert_allclose(np.hstack([F, G]), J, atol=1e-7)
    me = point_observation_model(np.array([2, 0]), np.tile(np.eye(2) * 0.4, (2, 1, 1)))
    H, _ = numerical_jacobian(lambda X, W: me.h(X), x, space, me.space, 0, 1e-7)
    np.testing.assert_allclose(me.jacobian(x), H, atol=1e-7)
    z = np.array([3.0, -1.0, 5.0, 2.0])
    aug = point_augmentation_model(3, z, np.tile(np.eye(2) * 0.4, (2, 1, 1)))
    F, G = aug.jacobian(x, z)
    J, _ = numerical_jacobian(lambda X, W: aug.f(X, z, W), x, space, aug.space, 4, 1e-7)
    np.testing.assert_allclose(np.hstack([F, G]), J, atol=1e-7)
    # the measurement inverts the augmentation
    y = aug.f(x[None, :], z, np.zeros((1, 4)))[0]
    me2 = point_observation_model(np.array([3, 4]), np.tile(np.eye(2), (2, 1, 1)))
    np.testing.assert_allclose(me2.h(y[None, :])[0], z, atol=1e-12)
