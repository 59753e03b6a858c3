r"""Linearisation of models in tangent coordinates: the EKF's Jacobian selection (the
model's analytic Jacobian if it has one, else a central difference through the spaces),
shared by the EKF's own steps and its partitioned (local-mode) steps.

.. math::

    F = \frac{\partial\, f(\hat x \boxplus \delta) \boxminus f(\hat x)}{\partial \delta}\Big|_0
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .finite import require_finite, require_finite_input
from .linalg import Array
from .models import Measurement, Transition
from .spaces import Space


def numerical_jacobian(fn: Callable[[Array, Array], Array], x: Array, space_in: Space,
                       space_out: Space, nw: int = 0, eps: float = 1e-6
                       ) -> tuple[Array, Array]:
    """Central-difference Jacobian through the spaces, all perturbations in one batch.

    Parameters
    ----------
    fn : callable
        ``fn(X (m, nx), W (m, nw)) -> (m, ny)``.
    x : (nx,) point where to differentiate (``W = 0``), or (..., nx) for a batch.

    Returns
    -------
    J : (d_out, d_in + nw) array
    y0 : (ny,) the value ``fn(x, 0)``.
    """
    d = space_in.dim
    n = d + nw
    steps = np.vstack([eps * np.eye(n), -eps * np.eye(n)])
    if x.ndim == 1:
        Y = fn(space_in.retract(x, steps[:, :d]), steps[:, d:])
        y0 = fn(x[None, :], np.zeros((1, nw)))[0]
        require_finite("model output", Y, y0)
        dY = space_out.local(y0, Y)
        return ((dY[:n] - dY[n:]) / (2.0 * eps)).T, y0
    lead = x.shape[:-1]  # a batch of linearisation points
    Y = fn(space_in.retract(x[..., None, :], steps[:, :d]),
           np.broadcast_to(steps[:, d:], lead + (2 * n, nw)))
    y0 = fn(x[..., None, :], np.zeros(lead + (1, nw)))[..., 0, :]
    require_finite("model output", Y, y0)
    dY = space_out.local(y0[..., None, :], Y)
    return np.swapaxes((dY[..., :n, :] - dY[..., n:, :]) / (2.0 * eps), -1, -2), y0


def linearise_transition(model: Transition, x: Array, u: Any, space_in: Space,
                         space_out: Space, eps: float = 1e-6
                         ) -> tuple[Array, Array | None, Array]:
    r"""The EKF's Jacobian selection for a transition at ``x``: ``(F, G, y)``.

    :math:`F = \partial f/\partial\delta` (tangent in, tangent out), :math:`G = \partial
    f/\partial w` at :math:`w = 0` (``None`` for additive noise) and :math:`y = f(x, u[, 0])`;
    analytic when ``model.jacobian`` is given, else :func:`numerical_jacobian` through
    ``space_in`` / ``space_out``.  A non-finite output raises
    :class:`~estimators.finite.NonFiniteError`.
    """
    require_finite_input(u)
    F, G, y = _linearise_transition(model, x, u, space_in, space_out, eps)
    require_finite("transition output", y)
    require_finite("transition Jacobian", F, G)
    return F, G, y


def _linearise_transition(model: Transition, x: Array, u: Any, space_in: Space,
                          space_out: Space, eps: float) -> tuple[Array, Array | None, Array]:
    if model.additive:
        if model.jacobian is not None:
            return model.jacobian(x, u), None, model.f(x[..., None, :], u)[..., 0, :]
        F, y = numerical_jacobian(lambda X, W: model.f(X, u), x, space_in, space_out, 0, eps)
        return F, None, y
    nw = model.noise.dim
    if model.jacobian is not None:
        F, G = model.jacobian(x, u)
        return F, G, model.f(x[..., None, :], u, np.zeros(x.shape[:-1] + (1, nw)))[..., 0, :]
    J, y = numerical_jacobian(lambda X, W: model.f(X, u, W), x, space_in, space_out, nw, eps)
    return J[..., :space_in.dim], J[..., space_in.dim:], y


def linearise_measurement(model: Measurement, x: Array, space: Space, eps: float = 1e-6
                          ) -> tuple[Array, Array]:
    r"""The EKF's Jacobian selection for a measurement at ``x`` (on ``space``):
    :math:`(H, \hat z)` with :math:`H = \partial h/\partial\delta`, analytic when
    ``model.jacobian`` is given, else :func:`numerical_jacobian`; a non-finite output
    raises :class:`~estimators.finite.NonFiniteError`."""
    if model.jacobian is not None:
        H, zhat = model.jacobian(x), model.h(x[..., None, :])[..., 0, :]
    else:
        H, zhat = numerical_jacobian(lambda X, W: model.h(X), x, space, model.space, 0, eps)
    require_finite("measurement model output", zhat)
    require_finite("measurement Jacobian", H)
    return H, zhat
