r"""Extended Kalman filter on spaces (error-state form).

Jacobians are taken in tangent coordinates, either from the model
(``Transition.jacobian`` / ``Measurement.jacobian``) or numerically through the
spaces (:func:`numerical_jacobian`):

.. math::

    F = \frac{\partial\, f(\hat x \boxplus \delta) \boxminus f(\hat x)}{\partial \delta}\Big|_0,
    \qquad P' = F P F^\top + Q \ (+\, G Q_w G^\top),

    K = P H^\top (H P H^\top + R)^{-1},\quad
    \hat x^+ = \hat x \boxplus K(z \boxminus h(\hat x)),\quad
    P^+ = (I - KH) P (I - KH)^\top + K R K^\top \ \text{(Joseph form)}.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .linalg import Array, chol
from .models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from .sigma import _gain_tri
from .spaces import Space


def numerical_jacobian(fn: Callable[[Array, Array], Array], x: Array, space_in: Space,
                       space_out: Space, nw: int = 0, eps: float = 1e-6
                       ) -> tuple[Array, Array]:
    """Central-difference Jacobian through the spaces, all perturbations in one batch.

    Parameters
    ----------
    fn : callable
        ``fn(X (m, nx), W (m, nw)) -> (m, ny)``.
    x : (nx,) point where to differentiate (``W = 0``).

    Returns
    -------
    J : (d_out, d_in + nw) array
    y0 : (ny,) the value ``fn(x, 0)``.
    """
    d = space_in.dim
    n = d + nw
    steps = np.vstack([eps * np.eye(n), -eps * np.eye(n)])
    Y = fn(space_in.retract(x, steps[:, :d]), steps[:, d:])
    y0 = fn(x[None, :], np.zeros((1, nw)))[0]
    dY = space_out.local(y0, Y)
    return ((dY[:n] - dY[n:]) / (2.0 * eps)).T, y0


def ekf_predict(belief: Gaussian, model: Transition, u: Any = None, eps: float = 1e-6
                ) -> Gaussian:
    """EKF time update (additive or non-additive noise, optional change of space)."""
    m, P = belief.mean, belief.cov
    space = model.space or belief.space
    if model.additive:
        if model.jacobian is not None:
            F, y = model.jacobian(m, u), model.f(m[None, :], u)[0]
        else:
            F, y = numerical_jacobian(lambda X, W: model.f(X, u), m, belief.space, space,
                                      0, eps)
        Pn = F @ P @ F.T + model.noise.cov
    else:
        nw = model.noise.dim
        if model.jacobian is not None:
            F, G = model.jacobian(m, u)
            y = model.f(m[None, :], u, np.zeros((1, nw)))[0]
        else:
            J, y = numerical_jacobian(lambda X, W: model.f(X, u, W), m, belief.space, space,
                                      nw, eps)
            F, G = J[:, :belief.dim], J[:, belief.dim:]
        Pn = F @ P @ F.T + G @ model.noise.cov @ G.T
    return Gaussian(y, 0.5 * (Pn + Pn.T), space)


def ekf_update(belief: Gaussian, model: Measurement, z: Array, eps: float = 1e-6
               ) -> tuple[Gaussian, Innovation]:
    """EKF measurement update (Joseph form)."""
    m, P = belief.mean, belief.cov
    if model.jacobian is not None:
        H, zhat = model.jacobian(m), model.h(m[None, :])[0]
    else:
        H, zhat = numerical_jacobian(lambda X, W: model.h(X), m, belief.space, model.space,
                                     0, eps)
    nu = model.space.local(zhat, np.asarray(z, dtype=float))
    PHt = P @ H.T
    Pzz = H @ PHt + model.noise.cov
    Szz = chol(0.5 * (Pzz + Pzz.T))
    K = _gain_tri(PHt, Szz)
    A = np.eye(belief.dim) - K @ H
    Pn = A @ P @ A.T + K @ model.noise.cov @ K.T
    w = np.linalg.solve(Szz, nu)
    post = Gaussian(belief.space.retract(m, K @ nu), 0.5 * (Pn + Pn.T), belief.space)
    return post, Innovation(nu, Szz, float(w @ w))


@dataclass(frozen=True)
class ExtendedKalmanFilter:
    """EKF with the same interface as :class:`~estimators.sigma.SigmaPointFilter`."""

    name: str = "ekf"
    eps: float = 1e-6

    def init(self, mean: Array, space: Space, cov: Array | None = None,
             sqrt: Array | None = None) -> Gaussian:
        if cov is None:
            cov = np.asarray(sqrt) @ np.asarray(sqrt).T
        return Gaussian(np.asarray(mean, dtype=float), np.asarray(cov, dtype=float), space)

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Gaussian:
        return ekf_predict(_dense(belief), model, u, self.eps)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Gaussian, Innovation]:
        return ekf_update(_dense(belief), model, z, self.eps)


def _dense(belief: Belief) -> Gaussian:
    if isinstance(belief, SqrtGaussian):
        return Gaussian(belief.mean, belief.cov, belief.space)
    return belief
