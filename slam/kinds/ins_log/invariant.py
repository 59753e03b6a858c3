r"""Right-invariant variants of the log's sigma-point filters: what ``<filter>-inv`` means.

The log's 15-state INS ``[p, v, q_nb, b_g, b_a]`` (:mod:`nav.ins`) is the drone's vehicle
state, so its group is the drone's with no landmarks: :math:`SE_2(3)` with the biases
beside it, right-invariant error (:class:`nav.extended_pose_group.ExtendedPoseGroup`, the
"imperfect" invariant filter of Barrau & Bonnabel 2017; sigma points as Brossard et al.
2020; the drone's ``srckf-inv``, :mod:`slam.kinds.drone.variants`).  A variant is no new
filter code: the base filter runs on the same mechanisation (the points' preintegrated
prediction) and the same GNSS model :math:`h(x)` with

* the state space the group (the points drawn, averaged and corrected on it);
* the prior and the process noise carried to the group error,
  :math:`P_ξ = M(\hat x_0)^{-1} P_0 M^{-\top}`, :math:`Q_ξ = M(y)^{-1} Q M(y)^{-\top}` at
  the mean's end point :math:`y = f(\hat x)` (factors: :math:`M^{-1} S`), :math:`M` the
  Jacobian of the standard error ``[δp, δv, δθ_body, δb]`` in the group's
  (:meth:`~nav.extended_pose_group.ExtendedPoseGroup.to_world`);
* the recorded covariance carried back, :math:`P = M P_ξ M^\top` at each estimate (first
  order), so the scores read the same position covariance as the other filters'.

Only the sigma-point filters have variants: they use :math:`f` and :math:`h` alone, while
the EKF would need its :math:`Φ` and :math:`H` carried too.
"""

from __future__ import annotations

import numpy as np

from estimators.linalg import Array, chol
from estimators.models import Noise, Transition
from nav.extended_pose_group import ExtendedPoseGroup

GROUP = ExtendedPoseGroup(0, "right")
"""The state space of an invariant variant (ambient ``[p, v, q, b_g, b_a]``, tangent
``[ξ_p, ξ_v, ξ_θ, δb_g, δb_a]``)."""
BASES: tuple[str, ...] = ("ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf")
VARIANTS: tuple[str, ...] = tuple(f"{b}-inv" for b in BASES)


def is_invariant(name: str) -> bool:
    """``name`` is an invariant variant (``<base>-inv``)."""
    return name in VARIANTS


def group_prior(x0: Array, P0: Array) -> Array:
    """A factor of the prior in the group error: :math:`M(x_0)^{-1}\\,\\mathrm{chol}(P_0)`."""
    return GROUP.from_world(x0, chol(P0))


def group_transition(model: Transition, x_mean: Array) -> Transition:
    """``model`` (additive tangent noise in the standard chart) with its noise carried to
    the group error at the mean's end point (module docstring)."""
    y = model.f(np.asarray(x_mean, dtype=float)[None], None)[0]
    return Transition(model.f, Noise.from_sqrt(GROUP.from_world(y, model.noise.sqrt)),
                      additive=True)


def world_covariances(means: Array, covs: Array) -> Array:
    """The recorded group-error covariances (E, 15, 15) as standard-chart ones,
    :math:`M P_ξ M^\\top` at each estimate (NaN where the estimate is not finite)."""
    out = np.full_like(covs, np.nan)
    for e, (x, P) in enumerate(zip(means, covs)):
        if np.all(np.isfinite(x)) and np.all(np.isfinite(P)):
            out[e] = GROUP.to_world(x, GROUP.to_world(x, P).T).T
    return out
