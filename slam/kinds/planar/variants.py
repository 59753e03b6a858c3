r"""Error-space and Jacobian-policy variants of the planar SLAM filters: the one place that
says what ``<filter>-inv``, ``<filter>-linv`` and ``ekf-fej`` mean.

Design: a variant is not new filter code.  ``srckf-inv`` is the SRCKF run on a problem
whose state space is the SLAM group :math:`SE_{1+n}(2)` with right-invariant error
(:class:`estimators.slam_group.SlamGroup`, Barrau & Bonnabel 2015; with sigma points
Brossard et al. 2020); ``-linv`` the left-invariant error.  The models (car motion,
range-bearing, inverse observation) are unchanged ambient functions; only the EKF's analytic
Jacobians, given in the standard chart, are carried to the group error by the chain rule
(:func:`estimators.slam_group.invariant_jacobians`).  ``ekf-fej`` keeps the standard space
and changes the EKF's Jacobian policy (Huang et al. 2008, first-estimates Jacobian):

* motion :math:`F = [[I, J(\hat p_{k+1|k} - \hat p_{k|k-1})], [0, 1]]` (the compounded car
  model's exact form, with the prior pose's *first* estimate :math:`\hat p_{k|k-1}` instead
  of :math:`\hat p_{k|k}`); :math:`G` at the current estimate;
* measurement :math:`H` at the pose's first estimate :math:`\hat p_{k|k-1}` and each
  landmark's first estimate (its initialisation from the first sighting).

In ``local`` mode (:mod:`estimators.partitioned`) ``-inv`` / ``-linv`` keep the covariance
in the world chart, where the partitioned steps touch only the blocks a step names (with the
group error a prediction would move every landmark's error coordinates), and make every
correction on the group with the covariance transported to the new estimate
(:mod:`estimators.group_transport`, :func:`problem_for`).  For the EKF this is the
invariant EKF exactly (equal to joint mode to round-off, a test); for the sigma-point filters
the points are drawn in the world chart, so it equals joint mode to first order.
``ekf-fej`` is joint only (local mode's measurement sees block slots, not the landmarks'
identities).
Covariances are reported in the world frame ``(x, y, φ, l)`` to first order
(:meth:`SlamGroup.to_world <estimators.slam_group.SlamGroup.to_world>`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from estimators.filters import FILTER_NAMES
from estimators.linalg import Array
from estimators.models import Measurement, Transition
from estimators.partitioned import PARTITIONED_FILTERS
from estimators.slam_group import SlamGroup, invariant_h, invariant_jacobians
from slam.mapping.problem import variant_problem

#: Variant suffixes and the filters each applies to.
INVARIANT_BASES: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf",
                                    "iekf", "isrckf", "isrukf")
VARIANTS: dict[str, tuple[str, ...]] = {"inv": INVARIANT_BASES, "linv": INVARIANT_BASES,
                                        "fej": ("ekf",)}
#: Every variant name (``<base>-<suffix>``).
VARIANT_NAMES: tuple[str, ...] = tuple(f"{b}-{v}" for v, bases in VARIANTS.items()
                                       for b in bases)
#: Every filter name a planar problem accepts.
PLANAR_FILTERS: tuple[str, ...] = FILTER_NAMES + VARIANT_NAMES
SIDES = {"inv": "right", "linv": "left"}
#: Every filter name a planar problem accepts in local mode.
PLANAR_LOCAL_FILTERS: tuple[str, ...] = PARTITIONED_FILTERS + tuple(
    f"{b}-{v}" for v in SIDES for b in INVARIANT_BASES if b in PARTITIONED_FILTERS)


def split_variant(name: str) -> tuple[str, str | None]:
    """``"srckf-inv" -> ("srckf", "inv")``; a plain name gives ``(name, None)``."""
    base, _, suffix = name.rpartition("-")
    if base and suffix in VARIANTS and base in VARIANTS[suffix]:
        return base, suffix
    return name, None


def problem_for(make: Callable[[str | None], Any], filter_name: str, mode: str) -> Any:
    """The planar problem ``make(variant)`` of ``filter_name`` in ``mode``
    (:func:`slam.mapping.problem.variant_problem`: local mode runs ``-inv`` / ``-linv`` on
    the standard problem with the group's transport)."""
    variant = split_variant(filter_name)[1]
    group = group_space_of(SIDES[variant]) if variant in SIDES else None
    return variant_problem(make, filter_name, variant, mode, PLANAR_LOCAL_FILTERS, group)


def group_space_of(side: str):
    """``n -> SlamGroup(n, side)``: the state spaces of a group-error planar problem."""
    def space_of(n: int) -> SlamGroup:
        return SlamGroup(n, side)  # type: ignore[arg-type]
    return space_of


def _n_landmarks(x: Array) -> int:
    return (x.shape[-1] - 3) // 2


def _remembering(model: Transition) -> tuple[Callable[..., Array], Callable[..., Array]]:
    """``(f, value)``: ``value(x, u)`` is :math:`f(x, u, 0)`, remembered so that the EKF's own
    evaluation of ``f`` at the same mean right after its Jacobian reuses it (the same
    numbers, computed once); every other call goes to ``model.f``.  ``x`` may be a batch of
    means (..., n), the EKF's points then (..., 1, n)."""
    last: dict[str, Any] = {}

    def value(x: Array, u: Any) -> Array:
        x = np.asarray(x, dtype=float)
        y = model.f(x[..., None, :], u, np.zeros(x.shape[:-1] + (1, model.noise.dim)))
        y = y[..., 0, :]
        last.update(x=np.array(x, dtype=float, copy=True), u=u, y=y)
        return y

    def f(X: Array, u: Any, W: Array) -> Array:
        if (last and X.shape[-2] == 1 and X.shape[:-2] == last["x"].shape[:-1]
                and u is last["u"] and not np.any(W)
                and np.array_equal(X[..., 0, :], last["x"])):
            return last["y"][..., None, :].copy()
        return model.f(X, u, W)

    return f, value


def _group_jacobian(model: Transition, side: str) -> Transition:
    """``model`` with its Jacobians carried to the group error of its input and output."""
    base = model.jacobian
    f, value = _remembering(model)

    def jacobian(x: Array, u: Array) -> tuple[Array, Array | None]:
        F, G = base(x, u)
        y = value(x, u)
        sp_in = SlamGroup(_n_landmarks(x), side)  # type: ignore[arg-type]
        sp_out = SlamGroup(_n_landmarks(y), side)  # type: ignore[arg-type]
        return invariant_jacobians(sp_in, sp_out, x, y, F, G)

    # ``moves`` (ambient: the pose moves, the map is copied) holds on the group too; the
    # structured steps see the group space and take its own form (estimators.structured)
    return replace(model, f=f, jacobian=jacobian)


def invariant_motion(model: Transition, side: str) -> Transition:
    """The motion model with its analytic Jacobians carried to the group error."""
    return _group_jacobian(model, side)


def invariant_augment(model: Transition, side: str) -> Transition:
    """The augmentation into the bigger group, Jacobians carried to the group error."""
    n_out = (model.space.dim - 3) // 2
    return replace(_group_jacobian(model, side),
                   space=SlamGroup(n_out, side))  # type: ignore[arg-type]


def invariant_observation(model: Measurement, side: str) -> Measurement:
    """A measurement (range-bearing, robot-frame point) with its Jacobian carried to the
    group error."""
    base = model.jacobian

    def jacobian(x: Array) -> Array:
        return invariant_h(SlamGroup(_n_landmarks(x), side), x,  # type: ignore[arg-type]
                           base(x))

    return replace(model, jacobian=jacobian)


class FirstEstimates:
    """FEJ bookkeeping for one run (Huang et al. 2008): the current epoch's first pose
    estimate :math:`\\hat p_{k|k-1}` and each landmark slot's first estimate.

    For planar motion models that move the position by heading-rotated increments (the car
    model, Pose2 odometry): their compounded :math:`F` is :math:`[[I, J(p_{end} -
    p_{start})], [0, 1]]` exactly, which :meth:`motion` evaluates at the first estimates.
    """

    def __init__(self, x0: Array):
        self.pose = np.array(x0[:3], dtype=float)
        self.landmarks: dict[int, Array] = {}

    def motion(self, model: Transition, x: Array, u: Array) -> Transition:
        """``model`` with :math:`F` at the first estimates; moves the pose's first estimate
        to the prediction from ``x`` (the mean the EKF predicts from)."""
        start = self.pose
        end = model.f(np.asarray(x, dtype=float)[None, :3], u,
                      np.zeros((1, model.noise.dim)))[0]
        self.pose = end.copy()
        base = model.jacobian

        def jacobian(xx: Array, uu: Array) -> tuple[Array, Array]:
            F, G = base(xx, uu)
            F = F.copy()
            F[0, 2] = -(end[1] - start[1])
            F[1, 2] = end[0] - start[0]
            return F, G

        return replace(model, jacobian=jacobian)

    def observation(self, model: Measurement, slots: Array) -> Measurement:
        """``model`` with :math:`H` at the pose's and the landmarks' first estimates
        (joint mode: ``slots`` are the state's slots)."""
        slots = np.asarray(slots, dtype=int)
        base = model.jacobian

        def jacobian(x: Array) -> Array:
            xf = np.array(x, dtype=float, copy=True)
            xf[:3] = self.pose
            for s in slots:
                xf[3 + 2 * s:5 + 2 * s] = self.landmarks[int(s)]
            return base(xf)

        return replace(model, jacobian=jacobian)

    def augment(self, model: Transition, n_before: int) -> Transition:
        """``model`` recording each new landmark's first estimate (the EKF evaluates the
        Jacobian once, at the mean: the landmark's initialisation)."""
        base = model.jacobian

        def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
            x = np.asarray(x, dtype=float)
            y = model.f(x[None, :], u, np.zeros((1, model.noise.dim)))[0]
            for i, xy in enumerate(y[x.shape[0]:].reshape(-1, 2)):
                self.landmarks[n_before + i] = xy.copy()
            return base(x, u)

        return replace(model, jacobian=jacobian)
