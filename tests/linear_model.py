"""The linear-Gaussian test model every filter must reduce to the Kalman filter on.

Shared by the tests of the Kalman filters and of the H∞ filters.
"""

from __future__ import annotations

import numpy as np

from estimators import Measurement, Noise, Transition

F = np.array([[1.0, 0.1, 0.005, 0.0],
              [0.0, 1.0, 0.1, 0.0],
              [0.0, 0.0, 0.98, 0.0],
              [0.02, 0.0, 0.0, 0.95]])
B = np.array([[0.0], [0.0], [0.1], [0.05]])
H = np.array([[1.0, 0.0, 0.0, 0.5],
              [0.0, 0.0, 1.0, -1.0]])
Q = np.diag([1e-4, 1e-3, 1e-2, 4e-3])
R = np.array([[0.3, 0.05], [0.05, 0.2]])


def linear_models(with_jacobians: bool = False) -> tuple[Transition, Measurement]:
    """``x' = F x + B u + w``, ``z = H x + v`` (Jacobians given to the EKF on request)."""
    tr = Transition(lambda X, u: X @ F.T + (B @ u), Noise.from_cov(Q),
                    jacobian=(lambda x, u: F) if with_jacobians else None)
    me = Measurement(lambda X: X @ H.T, Noise.from_cov(R),
                     jacobian=(lambda x: H) if with_jacobians else None)
    return tr, me


def simulate_linear(n_steps: int, seed: int) -> tuple[list, list]:
    """Controls and measurements of one seeded run of the model."""
    rng = np.random.default_rng(seed)
    x = np.array([1.0, -0.5, 0.3, 2.0])
    us, zs = [], []
    for k in range(n_steps):
        u = np.array([np.sin(0.05 * k)])
        x = F @ x + B @ u + rng.multivariate_normal(np.zeros(4), Q)
        us.append(u)
        zs.append(H @ x + rng.multivariate_normal(np.zeros(2), R))
    return us, zs
