r"""The ship's state, process model and the four quaternion treatments.

State
-----
``x = [q_nb, α]`` (attitude quaternion and gyro drift, rad/s): ambient 7, tangent 6, with
the body-frame right perturbation :math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)`,
:math:`\alpha = \hat\alpha + \delta\alpha` - the chart GTSAM's ``Rot3.retract`` uses, so
filter and smoother covariances compare directly.

Process model ([Ding 2017] eq. 4-6), one step per vector interval
-----------------------------------------------------------------
:math:`\dot q = \tfrac12 \Omega(\bar\omega - \alpha) q - \tfrac12 M(q)\mu_v` (eq. 6) in the
Earth-fixed navigation frame, integrated over the ``n`` gyro samples of the interval
:math:`T = n\,dt` with the drift held:

.. math::

    q' = \mathrm{Exp}(-\omega_{ie}^n T) \otimes q \otimes
         \prod_{k} \mathrm{Exp}((\tilde\omega_k - \alpha)\,dt),\qquad \alpha' = \alpha .

The Earth-rate factors of the samples, :math:`\mathrm{Exp}(-\omega_{ie}^n dt)` on the left of
each step, commute past the body increments on the right and collect into one.  The gyro
noise :math:`-\tfrac12 M(q)\mu_v` (eq. 6) is :math:`q \otimes [0, -\mu_v/2]`, i.e. the
tangent noise :math:`\delta\theta = -\mu_v\,dt` per sample, and the drift noise
:math:`\mu_u` (eq. 5) a random walk of :math:`\alpha`; over the interval they add
:func:`nav.gyro.interval_noise` in the tangent (additive).  Every filter and treatment
uses this one model, so the comparisons below isolate the point rule, the mean and the
measurement model.

Treatments of the quaternion
----------------------------
``paper``
    [Ding 2017]'s: the pseudo-observation :math:`Z_j = G_j q` (eq. 8-9), observed as
    :math:`0`, with the noise-separation covariance of its quaternion-dependent noise
    :math:`-\tfrac12 M(q)\mu_j` (eq. 15-16) evaluated at the prior
    (:func:`nav.pseudo_observation.pseudo_observation_model`, with the second moment of
    the prior's quaternion corrected: :func:`pseudo_observations`), and the weighted
    quaternion mean by the Lagrange-multiplier (eigenvector) method (§1.4,
    :class:`nav.quaternion_mean.EigenMeanQuaternion`).
``additive``
    The same pseudo-observation; the sigma-point mean is the weighted sum of the
    sign-aligned quaternions, renormalised (:class:`AdditiveMeanQuaternion`) - the mean
    §1.4's Lagrange method replaces.
``chart``
    The same pseudo-observation; the iterative weighted mean in the
    :math:`q \otimes \mathrm{Exp}(\delta)` chart (:class:`nav.spaces.UnitQuaternion`).
``manifold``
    The plain vector measurement :math:`\bar B_j = C(q)^\top R_j + \mu_j` (eq. 7) with
    :math:`R = \mathrm{diag}(\sigma_j^2 I_3)` (:func:`nav.observations.direction_measurement`)
    and the chart mean: the MEKF / SRCKF treatment.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators import Euclidean, Measurement, Product, Transition
from estimators.models import Belief
from nav.gyro import interval_transition
from nav.observations import direction_measurement
from nav.pseudo_observation import pseudo_observation_model
from nav.quaternion import qexp, qmul, qnormalize
from nav.quaternion_mean import EigenMeanQuaternion
from nav.spaces import UnitQuaternion
from slam.kinds.ship.simulate import ShipLog

Array = NDArray[np.float64]

__all__ = ["AdditiveMeanQuaternion", "Treatment", "earth_rate_transition", "label",
           "pseudo_observations", "treatment"]


@dataclass(frozen=True)
class AdditiveMeanQuaternion(UnitQuaternion):
    r""":class:`nav.spaces.UnitQuaternion` (its chart) with the additive quaternion mean

    .. math::  \bar q = \frac{\sum_i w_i s_i q_i}{\lVert\sum_i w_i s_i q_i\rVert},
        \qquad s_i = \mathrm{sign}(q_i^\top q_{i^*}),

    :math:`q_{i^*}` the largest-weight point (the first on ties).  For a cloud of spread
    :math:`\sigma` it differs from the eigenvector and chart means by :math:`O(\sigma^3)`.
    """

    def mean(self, points: ArrayLike, weights: ArrayLike) -> Array:
        pts = np.asarray(points, dtype=np.float64)
        w = np.asarray(weights, dtype=np.float64)
        ref = pts[int(np.argmax(w))]
        return qnormalize(w @ (pts * np.where(pts @ ref < 0.0, -1.0, 1.0)[:, None]))


def earth_rate_transition(n: int, dt: float, arw: float, bias_rw: float,
                          earth_rate: ArrayLike) -> Transition:
    """One vector interval of ``n`` gyro samples (module docstring): :func:`nav.gyro.
    interval_transition` with the navigation frame's Earth-rate turn on the left."""
    base = interval_transition(n, dt, arw, bias_rw)
    turn = qexp(-np.asarray(earth_rate, dtype=np.float64) * (n * dt))

    def f(X: Array, u: Array) -> Array:
        out = base.f(X, u)
        out[:, :4] = qmul(turn, out[:, :4])
        return out

    return replace(base, f=f)


def pseudo_observations(B: Array, refs: Array, sigmas: Array, q_hat: Array, P_att: Array
                        ) -> Measurement:
    r"""The stacked pseudo-observations of all vectors, whitened (observe ``0``).

    :func:`nav.pseudo_observation.pseudo_observation_model` takes one σ for all its
    vectors, and gravity and the field have different σ.  :math:`G(B, R)` is linear in
    :math:`(B, R)` jointly, so dividing the pair by :math:`\sigma_j` divides
    :math:`Z_j = G_j q` and its noise :math:`-\tfrac12 M(q)\mu_j` by :math:`\sigma_j` and
    leaves :math:`\mu_j/\sigma_j \sim N(0, I_3)`: one model with :math:`\sigma = 1` on the
    scaled pairs is the stack of the per-vector models, each row scaled by a constant -
    which a Kalman update does not see (eq. 8-9, noise by eq. 15-16 at the prior
    ``q_hat``, ``P_att``).

    The noise uses the second moment of the prior's quaternion (the library's model):
    after the projection :math:`T = \Xi(\hat q)^\top` each whitened block is
    :math:`\tfrac14 I - P/16`.
    """
    scale = 1.0 / np.asarray(sigmas, dtype=np.float64)[:, None]
    return pseudo_observation_model(B * scale, refs * scale, 1.0, q_hat, P_att)


@dataclass(frozen=True)
class Treatment:
    """How a filter sees the quaternion: its state space and its measurement."""

    name: str
    space: Product
    pseudo: bool

    def measurement(self, belief: Belief, log: ShipLog, j: int,
                    vector_model: Measurement) -> tuple[Measurement, Array]:
        """The model and the observation of vector epoch ``j`` for the prior ``belief``."""
        if not self.pseudo:
            return vector_model, log.vectors[j].ravel()
        P = belief.cov_block(np.arange(3))
        m = pseudo_observations(log.vectors[j], log.refs, log.sigmas, belief.mean[:4], P)
        return m, np.zeros(m.noise.dim)


_SPACES = {"paper": EigenMeanQuaternion(), "additive": AdditiveMeanQuaternion(),
           "chart": UnitQuaternion(), "manifold": UnitQuaternion()}


def treatment(name: str) -> Treatment:
    """The :class:`Treatment` called ``name`` (one of ``slam.kinds.ship.world.TREATMENTS``)."""
    return Treatment(name, Product([_SPACES[name], Euclidean(3)]), name != "manifold")


def vector_measurement(log: ShipLog) -> Measurement:
    """The plain vector measurement of the log's references (``manifold`` treatment)."""
    return direction_measurement(log.refs, log.sigmas[:, None])


def label(filter_name: str, treatment_name: str, main: bool) -> str:
    """The estimator's name in the summary: the filter's for a main run, else
    ``"filter:treatment"``."""
    return filter_name if main else f"{filter_name}:{treatment_name}"
