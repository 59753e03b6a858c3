"""The car model's batched Jacobians (closed form of the shear chain) against the per-run
step-by-step chain and against finite differences of the model itself."""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.planar.models import motion_model


@pytest.mark.parametrize("n_steps", [1, 3, 8])
def test_batched_jacobians_are_the_per_run_chain(n_steps):
    rng = np.random.default_rng(n_steps)
    m = motion_model(0.025, 4.0, np.diag([0.09, 0.003]), n_steps)
    x = rng.normal(size=(6, 9)) * 5.0
    x[:, 2] = rng.uniform(-np.pi, np.pi, 6)
    x[0, 2] = np.pi - 1e-3  # a heading that wraps along the steps
    u = np.stack([rng.uniform(0.0, 40.0, (6, n_steps)), rng.uniform(-0.6, 0.6, (6, n_steps))],
                 axis=-1)
    F, G = m.jacobian(x, u)
    for j in range(6):
        F1, G1 = m.jacobian(x[j], u[j])
        np.testing.assert_allclose(F[j], F1, rtol=0, atol=1e-12 * np.abs(F1).max())
        np.testing.assert_allclose(G[j], G1, rtol=0, atol=1e-12 * np.abs(G1).max())
    # and the model's own derivative (central differences) at one member
    eps, j = 1e-6, 2
    X = x[j] + eps * np.vstack([np.eye(9), -np.eye(9)])
    Y = m.f(X, u[j], np.zeros((18, 2 * n_steps)))
    Fd = (Y[:9] - Y[9:]).T / (2 * eps)
    Fd[2] = (np.angle(np.exp(1j * (Y[:9, 2] - Y[9:, 2])))) / (2 * eps)
    np.testing.assert_allclose(F[j], Fd, atol=1e-6 * np.abs(Fd).max())
    W = eps * np.vstack([np.eye(2 * n_steps), -np.eye(2 * n_steps)])
    Yw = m.f(np.broadcast_to(x[j], (4 * n_steps, 9)), u[j], W)
    Gd = (Yw[:2 * n_steps] - Yw[2 * n_steps:]).T / (2 * eps)
    np.testing.assert_allclose(G[j], Gd, atol=1e-6 * np.abs(Gd).max())
