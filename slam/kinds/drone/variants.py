r"""Invariant-error variants of the drone's SINS/SLAM filters: what ``<filter>-inv`` means.

Design (as :mod:`slam.kinds.planar.variants`): a variant is not new filter code.
``srckf-inv`` is the SRCKF on a problem whose state space is the extended-pose SLAM group
:math:`SE_{2+n}(3)` with the IMU biases beside it and right-invariant error
(:class:`nav.extended_pose_group.ExtendedPoseGroup`; the "imperfect" invariant
filter of Barrau & Bonnabel 2017, with sigma points Brossard et al. 2020).  The ambient
state and the tangent order are the drone's, so the mechanisation, the range / azimuth /
elevation model, the inverse observation, the slices and the scores are unchanged.  What
changes is given in the standard chart and carried to the group error by the chain rule,
with :math:`M(x) = \partial(\text{standard error})/\partial ξ`:

* process noise, added at the end of the epoch: :math:`Q_ξ = M(y)^{-1} Q M(y)^{-\top}`
  (factor :math:`M(y)^{-1} S`) at the mean's mechanised end point :math:`y = f(\hat x)`;
  it now has landmark rows, since the attitude noise moves every vector's invariant error;
* the EKF's :math:`F_ξ = M(y)^{-1}\,\mathrm{blkdiag}(Φ, I)\,M(\hat x)`;
* the augmentation's :math:`F_ξ = M(y)^{-1} F M(\hat x)`, :math:`G_ξ = M(y)^{-1} G`;
* the range / azimuth / elevation Jacobian :math:`H_ξ = H M(\hat x)`.

With right-invariant error the four unobservable directions of SINS/SLAM - a rotation of
the scene about gravity and the three translations - are the same tangent vectors at
every estimate, so the EKF's Jacobians cannot gain spurious information along them
(:func:`unobservable_directions`).  In ``local`` mode (ekf, srckf, srukf, srcdkf) a
prediction cannot run in the group error (it changes every landmark's error coordinates,
:math:`Q_ξ` has map rows, which the partitioned steps assume never happens): there the
covariance stays in the standard chart and each correction is made on the group with the
covariance transported (:mod:`estimators.group_transport`; the EKF equals joint mode to
round-off, the sigma-point filters to first order).  Covariances are reported in the
drone's standard chart to first order (``to_world``).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property, lru_cache

import numpy as np

from estimators.filters import FILTER_NAMES
from estimators.linalg import Array
from estimators.models import Measurement, Transition
from estimators.partitioned import PARTITIONED_FILTERS, BlockLayout
from nav.extended_pose_group import ExtendedPoseGroup, chain_jacobians
from slam.kinds.drone.models import (
    VEH_AMBIENT,
    VEH_DIM,
    ImuNoise,
    NavFrame,
    error_transition,
    propagate_points,
    psd_sqrt,
)

#: The filters with an invariant variant, and every variant name (``<base>-inv``).
INVARIANT_BASES: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf",
                                    "iekf", "isrckf", "isrukf")
VARIANT_NAMES: tuple[str, ...] = tuple(f"{b}-inv" for b in INVARIANT_BASES)
#: Every filter name a drone world accepts.
DRONE_FILTERS: tuple[str, ...] = FILTER_NAMES + VARIANT_NAMES
#: Every filter name a drone world accepts in local mode.
DRONE_LOCAL_FILTERS: tuple[str, ...] = PARTITIONED_FILTERS + tuple(
    f"{b}-inv" for b in INVARIANT_BASES if b in PARTITIONED_FILTERS)
VARIANTS: tuple[str, ...] = ("inv",)


def split_variant(name: str) -> tuple[str, str | None]:
    """``"srckf-inv" -> ("srckf", "inv")``; any other name gives ``(name, None)``."""
    base, _, suffix = name.rpartition("-")
    if suffix == "inv" and base in INVARIANT_BASES:
        return base, suffix
    return name, None


@lru_cache(maxsize=128)
def group_space(n_landmarks: int) -> ExtendedPoseGroup:
    """The state space of a right-invariant drone problem with ``n_landmarks`` (an
    immutable value, built once per size: every model and step asks for it)."""
    return ExtendedPoseGroup(n_landmarks, "right")


#: Block layout of the group state (the same sizes as the standard one).
GROUP_LAYOUT = BlockLayout.of(group_space)


def _n_landmarks(x: Array) -> int:
    return (np.shape(x)[-1] - VEH_AMBIENT) // 3


class _EndPoint:
    r"""The mean's mechanised end point :math:`y = f(\hat x)`, computed at most once: riding
    along as one extra row of the sigma points' own mechanisation when that comes first
    (the sigma-point filters), else mechanised alone (the EKF's Jacobian)."""

    def __init__(self, x_mean: Array, gyro: Array, accel: Array, nav: NavFrame):
        self.x, self.gyro, self.accel, self.nav = x_mean, gyro, accel, nav
        self.y: Array | None = None

    def value(self) -> Array:
        if self.y is None:
            self.y = propagate_points(self.x[None], self.gyro, self.accel, self.nav)[0]
        return self.y

    def f(self, X: Array, u: tuple[Array, Array]) -> Array:
        """The transition's ``f``: mechanise ``X`` through ``u``, reusing / recording y."""
        ours = u[0] is self.gyro and u[1] is self.accel
        if ours and self.y is not None and X.shape[0] == 1 and np.array_equal(X[0], self.x):
            return self.y[None].copy()
        if ours and self.y is None:
            Y = propagate_points(np.vstack([X, self.x]), u[0], u[1], self.nav)
            self.y = Y[-1]
            return Y[:-1]
        return propagate_points(X, u[0], u[1], self.nav)


class _GroupNoise:
    """:math:`Q_ξ = M(y)^{-1} Q M(y)^{-\top}` as a (d, 15) factor (the vehicle's noise moved
    into every vector's rows by :math:`M(y)^{-1}`), formed on first use, after the filter
    has propagated its points (a :class:`~estimators.models.Noise` in all but laziness)."""

    def __init__(self, space: ExtendedPoseGroup, end: _EndPoint, vehicle_sqrt: Array):
        self.space, self.end, self.vehicle_sqrt = space, end, vehicle_sqrt

    @property
    def dim(self) -> int:
        return self.space.dim

    @cached_property
    def sqrt(self) -> Array:
        S = np.zeros((self.space.dim, VEH_DIM))
        S[:VEH_DIM] = self.vehicle_sqrt
        return self.space.from_world(self.end.value(), S)

    @cached_property
    def cov(self) -> Array:
        return self.sqrt @ self.sqrt.T


def invariant_imu_transition(x_mean: Array, n_landmarks: int, gyro: Array, accel: Array,
                             nav: NavFrame, noise: ImuNoise) -> Transition:
    """:func:`~slam.kinds.drone.models.imu_transition` in the group error: the same
    mechanisation, :math:`Q_ξ` and (for the EKF) :math:`F_ξ` (module docstring), both
    at the mean's end point :math:`y`, which is mechanised once (:class:`_EndPoint`)."""
    x_mean = np.array(x_mean, dtype=float, copy=True)
    Phi, Qv = error_transition(x_mean, gyro, accel, nav, noise)
    sp = group_space(n_landmarks)
    end = _EndPoint(x_mean, gyro, accel, nav)

    def jacobian(x: Array, u: tuple[Array, Array]) -> Array:
        F = np.eye(sp.dim)
        F[:VEH_DIM, :VEH_DIM] = Phi
        return chain_jacobians(sp, sp, x_mean, end.value(), F)[0]

    return Transition(end.f, _GroupNoise(sp, end, psd_sqrt(Qv)),  # type: ignore[arg-type]
                      additive=True, jacobian=jacobian)


def invariant_augmentation(model: Transition) -> Transition:
    """An augmentation (:func:`~slam.kinds.drone.models.augmentation_model`) into the
    bigger group, its Jacobians carried to the group error."""
    base = model.jacobian
    n_out = (model.space.ambient_dim - VEH_AMBIENT) // 3

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        F, G = base(x, u)
        y = model.f(np.asarray(x, dtype=float)[None], u, np.zeros((1, model.noise.dim)))[0]
        Fx, Gx = chain_jacobians(group_space(_n_landmarks(x)), group_space(n_out), x, y, F, G)
        return Fx, Gx  # type: ignore[return-value]

    return replace(model, space=group_space(n_out), jacobian=jacobian)


def invariant_observation(model: Measurement) -> Measurement:
    """A measurement of the drone state with its Jacobian carried to the group error."""
    base = model.jacobian

    def jacobian(x: Array) -> Array:
        return group_space(_n_landmarks(x)).right_world(x, base(x))

    return replace(model, jacobian=jacobian)


def unobservable_directions(n_landmarks: int) -> Array:
    """(d, 4) right-invariant error directions that no measurement sees and gravity-aligned
    motion keeps: a rotation of the scene about the vertical (ξ_θ = e_z) and the three
    translations (ξ_p = ξ_m = t); the same at every estimate."""
    d = VEH_DIM + 3 * n_landmarks
    N = np.zeros((d, 4))
    N[8, 0] = 1.0
    for start in [0, *range(VEH_DIM, d, 3)]:
        N[start:start + 3, 1:] = np.eye(3)
    return N
