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


def _stepped(X, u, W, dt, wheelbase):
    """The car model stepped one control at a time (the motion equations as written):
    X (R, m, n), u (R, s, 2), W (R, m, 2 s)."""
    Y = np.array(X, dtype=float)
    for i in range(u.shape[-2]):
        V = u[:, i, 0:1] + W[..., 2 * i]
        G = u[:, i, 1:2] + W[..., 2 * i + 1]
        a = G + Y[..., 2]
        Y[..., 0] += V * dt * np.cos(a)
        Y[..., 1] += V * dt * np.sin(a)
        Y[..., 2] = Y[..., 2] + V * dt * np.sin(G) / wheelbase
    Y[..., 2] = np.angle(np.exp(1j * Y[..., 2]))
    return Y


@pytest.mark.parametrize("n_steps", [1, 2, 8])
def test_all_steps_at_once_equal_stepping(n_steps):
    """f gives the stepped model's poses (to round-off, a batch of runs and
    one run alike); the map is copied, the heading wrapped, the caller's arrays untouched."""
    rng = np.random.default_rng(10 + n_steps)
    dt, wb = 0.025, 4.0
    m = motion_model(dt, wb, np.diag([0.09, 0.003]), n_steps)
    X = rng.normal(size=(3, 7, 9)) * 5.0
    X[..., 2] = rng.uniform(-np.pi, np.pi, (3, 7))
    X[0, 0, 2] = np.pi - 1e-4  # wraps along the steps
    u = np.stack([rng.uniform(0.0, 40.0, (3, n_steps)), rng.uniform(-0.6, 0.6, (3, n_steps))],
                 axis=-1)
    W = rng.normal(size=(3, 7, 2 * n_steps)) * 0.3
    before = (X.copy(), u.copy(), W.copy())
    Y = m.f(X, u, W)
    ref = _stepped(X, u, W, dt, wb)
    np.testing.assert_allclose(Y[..., :2], ref[..., :2], rtol=0, atol=1e-12)
    dth = np.angle(np.exp(1j * (Y[..., 2] - ref[..., 2])))
    assert np.abs(dth).max() < 1e-12
    assert np.all((Y[..., 2] >= -np.pi) & (Y[..., 2] < np.pi))
    np.testing.assert_array_equal(Y[..., 3:], X[..., 3:])
    for a, b in zip(before, (X, u, W)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(m.f(X[1], u[1], W[1]), Y[1])  # one run = its batch row
