r"""Extended Kalman filter on spaces (error-state form).

Jacobians are taken in tangent coordinates, either from the model
(``Transition.jacobian`` / ``Measurement.jacobian``) or numerically through the
spaces (:func:`estimators.linearise.numerical_jacobian`):

.. math::

    F = \frac{\partial\, f(\hat x \boxplus \delta) \boxminus f(\hat x)}{\partial \delta}\Big|_0,
    \qquad P' = F P F^\top + Q \ (+\, G Q_w G^\top),

    K = P H^\top (H P H^\top + R)^{-1},\quad
    \hat x^+ = \hat x \boxplus K(z \boxminus h(\hat x)),\quad
    P^+ = (I - KH) P (I - KH)^\top + K R K^\top \ \text{(Joseph form)}.

With a declared static tail (``Transition.moves``: :math:`F = \mathrm{diag}(F_v, I)`) the
prediction touches only the moved rows and columns of :math:`P`
(:func:`~estimators.structured.static_tail_cov`); with declared rows read
(``Measurement.reads``) the update uses those columns of :math:`H` only and the Joseph
form's value for the optimal gain, :math:`P - K (PH^\top)^\top`: both :math:`O(n^2)`
instead of :math:`O(n^3)`, equal to round-off (on coordinate-wise spaces only: a group
error, e.g. :class:`~estimators.slam_group.SlamGroup`, couples the rows).

The Jacobian selection (the model's analytic Jacobian if it has one, else
:func:`numerical_jacobian`) is :func:`linearise_transition` /
:func:`linearise_measurement`, shared with the EKF's block-local steps
(:meth:`ExtendedKalmanFilter.partitioned`, :mod:`estimators.partitioned`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .finite import require_finite
from .linalg import Array, chol, kalman_gain, matvec, nis_of, swap
from .linearise import linearise_measurement, linearise_transition
from .models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from .partitioned import BlockLayout, EkfBlockSteps
from .sigma_points import psd_factor
from .spaces import Space
from .structured import coordinatewise, enabled, static_tail_cov


def ekf_predict(belief: Gaussian, model: Transition, u: Any = None, eps: float = 1e-6
                ) -> Gaussian:
    """EKF time update (additive or non-additive noise, optional change of space)."""
    m, P = belief.mean, belief.cov
    space = model.space or belief.space
    F, G, y = linearise_transition(model, m, u, belief.space, space, eps)
    if (model.moves is not None and model.space is None and G is not None and enabled()
            and coordinatewise(belief.space)):
        return Gaussian(y, static_tail_cov(P, F, G, model.noise.cov, model.moves), space)
    if G is None:
        Pn = F @ P @ swap(F) + model.noise.cov
    else:
        Pn = F @ P @ swap(F) + G @ model.noise.cov @ swap(G)
    return Gaussian(y, 0.5 * (Pn + swap(Pn)), space)


def ekf_update(belief: Gaussian, model: Measurement, z: Array, eps: float = 1e-6
               ) -> tuple[Gaussian, Innovation]:
    """EKF measurement update (Joseph form)."""
    require_finite("measurement", z)
    m, P = belief.mean, belief.cov
    H, zhat = linearise_measurement(model, m, belief.space, eps)
    nu = model.space.local(zhat, np.asarray(z, dtype=float))
    declared = model.reads is not None and enabled() and coordinatewise(belief.space)
    rows = np.asarray(model.reads) if declared else None
    if rows is None:
        PHt = P @ swap(H)
        Pzz = H @ PHt + model.noise.cov
    else:  # declared: H is zero outside the rows read
        PHt = P[..., :, rows] @ swap(H[..., :, rows])
        Pzz = H[..., :, rows] @ PHt[..., rows, :] + model.noise.cov
    Szz = chol(0.5 * (Pzz + swap(Pzz)))
    K = kalman_gain(PHt, Szz)
    if rows is None:
        A = np.eye(belief.dim) - K @ H
        Pn = A @ P @ swap(A) + K @ model.noise.cov @ swap(K)
    else:  # the Joseph form's value for the optimal gain, O(n² nz)
        Pn = P - K @ swap(PHt)
    w = np.linalg.solve(Szz, nu) if nu.ndim == 1 else np.linalg.solve(Szz, nu[..., None])[..., 0]
    post = Gaussian(belief.space.retract(m, matvec(K, nu)), 0.5 * (Pn + swap(Pn)), belief.space)
    return post, Innovation(nu, Szz, nis_of(w))


@dataclass(frozen=True)
class ExtendedKalmanFilter:
    """EKF with the same interface as :class:`~estimators.sigma.SigmaPointFilter`, and
    block-local (partitioned) steps, :meth:`partitioned`."""

    name: str = "ekf"
    eps: float = 1e-6
    supports_partitioned: ClassVar[bool] = True
    #: Its steps accept a batch of beliefs (leading axis: the runs; :mod:`estimators.batch`).
    batched: ClassVar[bool] = True

    def init(self, mean: Array, space: Space, cov: Array | None = None,
             sqrt: Array | None = None) -> Gaussian:
        require_finite("prior mean", mean)
        require_finite("prior factor", sqrt)
        if cov is None:
            cov = np.asarray(sqrt) @ np.asarray(sqrt).T
        else:
            require_finite("prior covariance", cov)
            psd_factor(np.asarray(cov, dtype=float))  # raises for a negative eigenvalue
        return Gaussian(np.asarray(mean, dtype=float), np.asarray(cov, dtype=float), space)

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Gaussian:
        return ekf_predict(_dense(belief), model, u, self.eps)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Gaussian, Innovation]:
        return ekf_update(_dense(belief), model, z, self.eps)

    def partitioned(self, layout: BlockLayout) -> EkfBlockSteps:
        """Block-local steps on a state laid out as ``layout`` (``local`` mode,
        :mod:`estimators.partitioned`), linearised by :func:`linearise_transition` /
        :func:`linearise_measurement` like :meth:`predict` / :meth:`update`."""
        return EkfBlockSteps(self, layout)


def _dense(belief: Belief) -> Gaussian:
    if isinstance(belief, SqrtGaussian):
        return Gaussian(belief.mean, belief.cov, belief.space)
    return belief
