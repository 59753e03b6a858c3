r"""Sigma-point Kalman filters: one predict/update pair for every rule and form.

Rules (:mod:`estimators.rules`): cubature, unscented, central difference.
Forms: ``"dense"`` keeps :math:`P`; ``"sqrt"`` keeps a lower-triangular factor built
by ``tria`` (QR) and Cholesky downdates; ``"svd"`` keeps a factor :math:`U\Sigma`
from an SVD.  With the rule's covariance factor :math:`[C \,|\, s_0 c_0]` of the
deviations of the propagated points:

Prediction (Arasaratnam & Haykin 2009, eqs. 38-42 for the cubature case):

.. math::

    \mathcal X_i = \hat x \boxplus S\xi_i,\quad
    \mathcal Y_i = f(\mathcal X_i, u),\quad
    \hat x' = \textstyle\mathrm{mean}_w(\mathcal Y),\quad
    S' = \mathrm{tria}([C,\ S_Q]) \pm c_0 .

Update (eqs. 43-51), with points redrawn from the predicted belief:

.. math::

    S_{zz} = \mathrm{tria}([C_z,\ S_R]),\quad
    P_{xz} = C_x C_z^\top,\quad
    K = P_{xz} S_{zz}^{-\top} S_{zz}^{-1},\quad
    \hat x^+ = \hat x \boxplus K (z \boxminus \hat z),\quad
    S^+ = \mathrm{tria}([C_x - K C_z,\ K S_R]) .

Non-additive noise (``Transition.additive = False``) is handled by drawing points
over the state augmented with the noise input.  A transition with its own
``space`` changes the state's dimension (used for SLAM landmark augmentation).

A model that declares a static tail (``Transition.moves``) or the rows it reads
(``Measurement.reads``) gets the structured square-root steps of
:mod:`estimators.structured` (equal to these to round-off); without a declaration, or
where a structured step does not apply, the dense steps above are taken.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import structured
from .finite import require_finite, require_finite_input
from .homm import HighOrderMoment, carry_update, drawn_rule, predicted_belief
from .linalg import (
    Array,
    NotPositiveDefiniteError,
    chol,
    kalman_gain,
    matvec,
    nis_of,
    outer,
    solve_lower,
    swap,
)
from .models import Belief, Gaussian, Innovation, Measurement, Noise, SqrtGaussian, Transition
from .partitioned import BlockLayout, SqrtSigmaBlockSteps, refuse_partitioned
from .rules import Factor, PointRule
from .sigma_points import Form, SqrtMethod, dense_cov, draw, factorise, prior_factor
from .spaces import Space


def _covariance(form: Form, fac: Factor, noise: Noise | None) -> Array:
    """The new belief's covariance (dense form) or factor (other forms)."""
    if form == "dense":
        return dense_cov(fac, None if noise is None else noise.cov)
    return factorise(form, fac, None if noise is None else noise.sqrt)


def _belief(form: Form, mean: Array, cov_or_sqrt: Array, space: Space) -> Belief:
    if form == "dense":
        return Gaussian(mean, cov_or_sqrt, space)
    return SqrtGaussian(mean, cov_or_sqrt, space)


def sigma_predict(rule: PointRule, form: Form, belief: Belief, model: Transition,
                  u: Any = None, method: SqrtMethod = "cholesky") -> Belief:
    """Time update: propagate sigma points through ``model.f``."""
    require_finite_input(u)
    if form == "sqrt" and model.moves is not None:  # a declared static tail
        out = structured.predict(rule, belief, model, u)
        if out is not None:
            return out
    r = drawn_rule(rule, belief, 0 if model.additive else model.noise.dim)  # HoMM moments
    if model.additive:
        X, _, _, wm = draw(r, belief, None, method)
        Y = model.f(X, u)
    else:
        X, W, _, wm = draw(r, belief, model.noise, method)
        Y = model.f(X, u, W)
    require_finite("transition output", Y)
    space = model.space or belief.space
    mean = space.mean(Y, wm)
    D = space.local(mean[..., None, :], Y)
    cov = _covariance(form, r.factor(D), model.noise if model.additive else None)
    out = _belief(form, mean, cov, space)
    return predicted_belief(rule, belief, out, D, wm, model.noise.cov if model.additive else None)


def sigma_update(rule: PointRule, form: Form, belief: Belief, model: Measurement,
                 z: Array, method: SqrtMethod = "cholesky") -> tuple[Belief, Innovation]:
    """Measurement update with points redrawn from ``belief`` (a batch of beliefs when its
    mean has leading axes; ``z`` then (..., nz))."""
    require_finite("measurement", z)
    if form == "sqrt" and model.reads is not None:  # declared rows read
        done = structured.update(rule, belief, model, z)
        if done is not None:
            return done
    rule = drawn_rule(rule, belief)  # HoMM: the predicted moments
    X, _, dX, wm = draw(rule, belief, None, method)
    Z = model.h(X)
    require_finite("measurement model output", Z)
    zspace = model.space
    zhat = zspace.mean(Z, wm)
    fac = rule.factor(np.concatenate([dX, zspace.local(zhat[..., None, :], Z)], axis=-1))
    d = belief.dim
    Cx, Cz = fac.C[..., :d, :], fac.C[..., d:, :]
    nu = zspace.local(zhat, np.asarray(z, dtype=float))
    Pxz = Cx @ swap(Cz)
    c0x = c0z = None
    if fac.c0 is not None:
        c0x, c0z = fac.c0[..., :d], fac.c0[..., d:]
        Pxz = Pxz + fac.sign * outer(c0x, c0z)
    zfac = Factor(Cz, c0z, fac.sign)
    R = model.noise
    if form == "dense":
        Pzz = _covariance("dense", zfac, R)
        Szz = chol(Pzz)
        K = kalman_gain(Pxz, Szz)
        P = belief.cov - K @ Pzz @ swap(K)
        post = 0.5 * (P + swap(P))
        w = solve_lower(Szz, nu)
    elif form == "sqrt":
        Szz = _covariance("sqrt", zfac, R)
        if not np.all(np.diagonal(Szz, axis1=-2, axis2=-1) > 0.0):
            raise NotPositiveDefiniteError("innovation covariance is singular")
        K = kalman_gain(Pxz, Szz)
        post = factorise("sqrt", _posterior_factor(Cx, Cz, K, c0x, c0z, fac.sign), K @ R.sqrt)
        w = solve_lower(Szz, nu)
    else:
        Szz = _covariance("svd", zfac, R)
        U, s, _ = np.linalg.svd(Szz, full_matrices=False)
        if not np.all(s > 0.0):
            raise NotPositiveDefiniteError("innovation covariance is singular")
        K = ((Pxz @ U) / (s**2)[..., None, :]) @ swap(U)
        post = factorise("svd", _posterior_factor(Cx, Cz, K, c0x, c0z, fac.sign), K @ R.sqrt)
        w = matvec(swap(U), nu) / s
    mean = belief.space.retract(belief.mean, matvec(K, nu))
    return (carry_update(belief, _belief(form, mean, post, belief.space)),
            Innovation(nu, Szz, nis_of(w)))


def _posterior_factor(Cx: Array, Cz: Array, K: Array, c0x: Array | None, c0z: Array | None,
                      sign: float) -> Factor:
    if c0x is None:
        return Factor(Cx - K @ Cz)
    return Factor(Cx - K @ Cz, c0x - matvec(K, c0z), sign)


@dataclass(frozen=True)
class SigmaPointFilter:
    """A sigma-point Kalman filter: a rule and a covariance form, nothing else.

    ``predict`` and ``update`` are pure: they return new beliefs and never keep
    anything for the next call.  The square-root form also has block-local
    (partitioned) steps, :meth:`partitioned`.
    """

    name: str
    rule: PointRule
    form: Form = "sqrt"
    sqrt_method: SqrtMethod = "cholesky"  # how a dense belief is factored to draw points

    def init(self, mean: Array, space: Space, cov: Array | None = None,
             sqrt: Array | None = None) -> Belief:
        """Initial belief from a covariance or (for singular priors) a factor."""
        mean = np.asarray(mean, dtype=float)
        require_finite("prior mean", mean)
        require_finite("prior covariance", cov)
        if sqrt is None:
            sqrt = prior_factor(np.asarray(cov, dtype=float))
        sqrt = np.asarray(sqrt, dtype=float)
        require_finite("prior factor", sqrt)
        if self.form == "dense":
            return Gaussian(mean, sqrt @ sqrt.T, space)
        return SqrtGaussian(mean, sqrt, space)

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Belief:
        self._single(belief)
        return sigma_predict(self.rule, self.form, belief, model, u, self.sqrt_method)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Belief, Innovation]:
        self._single(belief)
        return sigma_update(self.rule, self.form, belief, model, z, self.sqrt_method)

    def _single(self, belief: Belief) -> None:
        if np.ndim(belief.mean) > 1 and not self.batched:
            raise ValueError(f"{self.name} with predicted moments has no batched form; "
                             "run it per run")

    @property
    def batched(self) -> bool:
        """Its steps accept a batch of beliefs (leading axis: the runs;
        :mod:`estimators.batch`): every rule but the HoMM rule with predicted moments,
        whose moments are carried per belief."""
        return not (isinstance(self.rule, HighOrderMoment) and self.rule.moments == "predicted")

    @property
    def supports_partitioned(self) -> bool:
        """True for the square-root form: it has :meth:`partitioned` steps."""
        return self.form == "sqrt"

    def partitioned(self, layout: BlockLayout) -> SqrtSigmaBlockSteps:
        """Block-local steps on a state laid out as ``layout`` (``local`` mode,
        :mod:`estimators.partitioned`); the square-root form only, otherwise raises
        :class:`~estimators.partitioned.NoPartitionedModeError`."""
        if not self.supports_partitioned:
            refuse_partitioned(self.name)
        return SqrtSigmaBlockSteps(self, layout)
