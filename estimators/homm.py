r"""High-order moment-matching (HoMM) sigma points, [Ding 2017] §2-3 (eq. 18-23).

Reconstruction
--------------
Write the state as :math:`x = \bar x + S\xi` with :math:`S` a square factor of
:math:`P` and :math:`\xi` standardised (zero mean, identity covariance).  Along each
axis :math:`e_j` of :math:`\xi` the rule puts two points at *different* radii,

.. math::

    \xi_0 = 0,\qquad \xi_{j} = a_j\, e_j,\qquad \xi_{n+j} = -b_j\, e_j ,
    \qquad a_j, b_j > 0,

with weights

.. math::

    w_{j} = \frac{1}{a_j (a_j + b_j)},\qquad
    w_{n+j} = \frac{1}{b_j (a_j + b_j)},\qquad
    w_0 = 1 - \sum_{j} \frac{1}{a_j b_j}.

Per axis this gives :math:`E\xi_j = 0`, :math:`E\xi_j^2 = 1`,
:math:`E\xi_j^3 = a_j - b_j` and :math:`E\xi_j^4 = a_j^2 - a_j b_j + b_j^2`, so the
standardised third and fourth moments :math:`(s_j, k_j)` (skewness, kurtosis) are
matched by

.. math::

    a_j = \tfrac12\big(s_j + \sqrt{4k_j - 3s_j^2}\big),\qquad
    b_j = \tfrac12\big(-s_j + \sqrt{4k_j - 3s_j^2}\big),

which are both positive iff :math:`k_j > s_j^2` (true for every non-degenerate
distribution: :math:`k \ge s^2 + 1`).  This is [Ding 2017] eq. (20)/(22) with the paper's
:math:`\alpha\sqrt N = a`, :math:`\beta\sqrt N = b` and :math:`\phi_1 = s/\sqrt N`,
:math:`\phi_2 = k/N` (so :math:`N` cancels; the paper's weights
:math:`1/(\alpha(\alpha+\beta)N)` are the ones above).  The paper averages the moments
over the axes into one :math:`(\phi_1, \phi_2)`; here they may also be given per axis.

Mixed moments: :math:`E\xi_i\xi_j = 0` and all mixed third moments are zero
(:math:`i \ne j`), but :math:`E\xi_i^2\xi_j^2 = 0` (a Gaussian has 1): with
:math:`2n+1` points only the per-axis (marginal) fourth moments along the columns of
:math:`S` are matched.

For a Gaussian (:math:`s = 0, k = 3`): :math:`a = b = \sqrt3`, :math:`w_{\pm j} = 1/6`,
:math:`w_0 = 1 - n/3` - Julier's original unscented set with :math:`\kappa = 3 - n`
(mean and covariance weights equal).  :math:`w_0 < 0` for :math:`n > 3`; the factor
then carries a signed rank-one term, exactly as :class:`~estimators.rules.Unscented`.

Moments from the predicted points (``moments = "predicted"``: the paper's mechanism)
-------------------------------------------------------------------------------------
[Ding 2017] computes :math:`\phi_1, \phi_2` inside the recursion from the sigma points
themselves (§3 step 3 and the definitions after eq. 20): with the propagated points
:math:`\mathcal Y_i`, their weights :math:`w_i`, the predicted mean :math:`\hat x'` and
the lower Cholesky factor :math:`S'` of the predicted covariance :math:`P'`,

.. math::

    W_j = \sum_i w_i D_{ij}^3,\quad \Psi_j = \sum_i w_i D_{ij}^4,\quad
    D_i = \mathcal Y_i \boxminus \hat x',\qquad
    \phi_1 = \frac{\sum_j W_j}{\sqrt N \sum_{lk} S'^3_{lk}},\quad
    \phi_2 = \frac{\sum_j \Psi_j}{N \sum_{lk} S'^4_{lk}},

:math:`j` over the state's tangent components.  The rule then matches
:math:`s = \sqrt N\phi_1 = \sum_j W_j / \sum S'^3` and :math:`k = N\phi_2 = \sum_j
\Psi_j / \sum S'^4` - one skewness and one kurtosis averaged over the components
(weighted by their cubed / fourth-power spreads), the same on every axis of the next
draw.  For independent standardised components of skewness :math:`s` and kurtosis
:math:`k` and a diagonal :math:`S'` this returns :math:`(s, k)` exactly; for the rule's
own undistorted points (no mixed fourth moments) it returns its :math:`(s, k)` for any
:math:`S'`.  It is *not* the Gaussian's (0, 3) for a predicted set: a linear map mixes
the axes (per component :math:`\Psi_j = k\sum_c (AS)_{jc}^4`, which for the Gaussian
set, :math:`k = 3`, is less than a Gaussian's :math:`3(\sum_c (AS)_{jc}^2)^2`), a
nonlinear one adds skewness; and the normalisation by :math:`\sum S'^4` differs from
:math:`\sum_c (AS)_{jc}^4` whenever :math:`AS` is not triangular, so the kurtosis drifts
along a recursion even on a linear model (from 3 to 82 over the 200 steps of the linear
test model, ``tests/linear_model.py``).

With additive noise (``Transition.additive``) the points carry no noise: the predicted
distribution is :math:`y + w`, :math:`w \sim N(0, Q)` independent of :math:`y`, so
:math:`W_j` is the points' and :math:`\Psi_j` gains the noise's exact share
:math:`6\,P^y_{jj} Q_{jj} + 3 Q_{jj}^2` (:math:`P^y_{jj} = \sum_i w_i D_{ij}^2`).  With
non-additive noise the points were drawn over the state and the noise, as the paper
does, and :math:`D` already holds its effect.

The estimate travels with the predicted belief (:class:`MomentGaussian` /
:class:`MomentSqrtGaussian`, field :attr:`~MomentGaussian.moments`, a
:class:`PredictedMoments`); the update draws its points with it and its posterior
carries the same value unchanged (a Kalman update has no propagated points of its own);
the next prediction draws with it too, and replaces it.  The first draw (a prior
without moments) and the noise axes of an augmented draw use the stated ``skewness``
and ``kurtosis``.  An estimate that is not finite, or violates the validity condition
:math:`k > s^2` (else :math:`b \le 0`, eq. 20-22 give no points), or whose
:math:`S'` does not exist, is replaced by the stated values; the replacement is flagged
(:attr:`PredictedMoments.fallback`, the reason) and counted
(:attr:`PredictedMoments.fallbacks`), never silent.

On a linear-Gaussian model this filter is still the Kalman filter: every valid
:math:`(s, k)` gives points with the exact mean and covariance, and linear models use
nothing else (``tests/estimators/test_homm_predicted.py``), even though :math:`k \ne 3`
there.

Noise augmentation (eq. 22-23)
------------------------------
For :math:`x_k = f(x_{k-1}, w_{k-1})` the paper draws over :math:`[x; w]`
(:math:`N = n + m_1`): moment-matched points on the :math:`n` state axes and
:math:`\pm\sqrt N` points of weight :math:`1/(2N)` on the :math:`m_1` noise axes, the
centre weight taking up the rest.  Those noise points are this rule with
:math:`s = 0,\ k = N` on the noise axes: :func:`augmented_rule` builds exactly that set
(a rule valid for dimension :math:`N` only) for use with a non-additive
:class:`~estimators.models.Transition` in :func:`~estimators.sigma.sigma_predict`.
A :class:`~estimators.sigma.SigmaPointFilter` uses one rule for both steps, so with a
scalar :class:`HighOrderMoment` a non-additive transition gets matched moments
(:math:`k = 3` for Gaussian noise) on the noise axes as well - which matches the
Gaussian noise's fourth moment, where the paper's :math:`k = N` does only for
:math:`N = 3`.  Measurement noise is additive in this core
(:class:`~estimators.models.Measurement`), so the measurement-noise augmentation of the
update step is not needed: :math:`R` is added to :math:`P_{zz}` exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from .linalg import Array
from .models import Belief, Gaussian, SqrtGaussian
from .rules import Factor, signed_factor

__all__ = ["MOMENT_SOURCES", "HighOrderMoment", "MomentGaussian", "MomentSqrtGaussian",
           "PredictedMoments", "augmented_rule", "carry_update", "drawn_rule",
           "paper_moments", "predicted_belief", "standardised_moments"]

MOMENT_SOURCES = ("fixed", "predicted")
"""Where :class:`HighOrderMoment` takes the moments it matches: the stated ``skewness`` and
``kurtosis`` at every draw (``"fixed"``), or the predicted points' (``"predicted"``,
[Ding 2017]'s mechanism; module docstring)."""


def _per_axis(value: float | tuple[float, ...], n: int, what: str) -> tuple[float, ...]:
    if isinstance(value, tuple):
        if len(value) != n:
            raise ValueError(f"{what} is given for {len(value)} axes, the rule is asked for {n}")
        return tuple(float(v) for v in value)
    return (float(value),) * n


@lru_cache(maxsize=256)
def _homm_points(skew: tuple[float, ...], kurt: tuple[float, ...]) -> tuple[Array, Array]:
    s, k = np.array(skew), np.array(kurt)
    if not np.all(k > s**2):
        bad = int(np.argmin(k - s**2))
        raise ValueError(f"moment matching needs kurtosis > skewness**2 on every axis "
                         f"(axis {bad}: skewness {s[bad]}, kurtosis {k[bad]})")
    r = np.sqrt(4.0 * k - 3.0 * s**2)
    a, b = 0.5 * (s + r), 0.5 * (r - s)
    n = s.size
    xi = np.zeros((2 * n + 1, n))
    xi[1:n + 1] = np.diag(a)
    xi[n + 1:] = -np.diag(b)
    w = np.empty(2 * n + 1)
    w[1:n + 1] = 1.0 / (a * (a + b))
    w[n + 1:] = 1.0 / (b * (a + b))
    w[0] = 1.0 - np.sum(1.0 / (a * b))
    xi.setflags(write=False)
    w.setflags(write=False)
    return xi, w


@dataclass(frozen=True)
class HighOrderMoment:
    r"""HoMM sigma-point rule: :math:`2n+1` points matching mean, covariance and the
    per-axis standardised third and fourth moments (see the module docstring).

    Parameters
    ----------
    skewness : float or tuple of float
        :math:`E\xi_j^3` of the standardised variable; a scalar applies to every axis,
        a tuple fixes the dimension.  0 for a Gaussian.
    kurtosis : float or tuple of float
        :math:`E\xi_j^4`; 3 for a Gaussian.  Must exceed ``skewness**2`` per axis.
    moments : ``"fixed"`` or ``"predicted"``
        ``"fixed"``: ``skewness``/``kurtosis`` at every draw (with 0, 3: Julier's
        κ = 3 − n set).  ``"predicted"``: the moments of the predicted points
        (:func:`paper_moments`, carried by the predicted belief); ``skewness``/``kurtosis``
        (scalars) then serve the first draw, the noise axes and the fallback.
    """

    skewness: float | tuple[float, ...] = 0.0
    kurtosis: float | tuple[float, ...] = 3.0
    name: str = "high-order-moment"
    moments: str = "fixed"

    def __post_init__(self) -> None:
        if self.moments not in MOMENT_SOURCES:
            raise ValueError(f"moments must be one of {', '.join(MOMENT_SOURCES)}, "
                             f"got {self.moments!r}")
        if self.moments == "predicted":
            if isinstance(self.skewness, tuple) or isinstance(self.kurtosis, tuple):
                raise ValueError("predicted moments take scalar skewness and kurtosis "
                                 "(the first draw's, the same on every axis)")
            if not self.kurtosis > self.skewness**2:
                raise ValueError(f"moment matching needs kurtosis > skewness**2 "
                                 f"(skewness {self.skewness}, kurtosis {self.kurtosis})")

    @property
    def settings(self) -> dict[str, float | str]:
        return {"moments": self.moments, "skewness": self.skewness,  # type: ignore[dict-item]
                "kurtosis": self.kurtosis}

    def for_draw(self, belief: Belief, noise_dim: int = 0) -> HighOrderMoment:
        """The fixed rule this draw uses: ``self`` for fixed moments or a belief without
        predicted ones; else the belief's moments on its ``belief.dim`` axes and the stated
        ones on the ``noise_dim`` noise axes appended by an augmented draw."""
        m = getattr(belief, "moments", None)
        if self.moments == "fixed" or m is None:
            return self
        d = belief.dim
        return HighOrderMoment((m.skewness,) * d + (float(self.skewness),) * noise_dim,
                               (m.kurtosis,) * d + (float(self.kurtosis),) * noise_dim,
                               name=self.name)

    def points(self, n: int) -> tuple[Array, Array]:
        return _homm_points(_per_axis(self.skewness, n, "skewness"),
                            _per_axis(self.kurtosis, n, "kurtosis"))

    def factor(self, D: Array) -> Factor:
        """:math:`C = [\\sqrt{w_i} D_i]_{i \\ge 1}`; centre :math:`\\sqrt{|w_0|} D_0`, signed."""
        n = (D.shape[-2] - 1) // 2
        return signed_factor(D, self.points(n)[1])


@dataclass(frozen=True)
class PredictedMoments:
    r"""The moments a predicted belief carries to the next HoMM draw (module docstring).

    skewness, kurtosis : what the next draws match (:math:`s = \sqrt N\phi_1`,
        :math:`k = N\phi_2`); the stated values when the estimate was refused.

    estimate : the estimate :math:`(s, k)` itself (NaN when it could not be formed).
    fallback : ``None``, or why the estimate was refused this prediction.
    fallbacks, predictions : refused estimates and predictions so far in the recursion.
    """

    skewness: float
    kurtosis: float
    estimate: tuple[float, float]
    fallback: str | None
    fallbacks: int
    predictions: int


@dataclass(frozen=True)
class MomentGaussian(Gaussian):
    """A dense :class:`~estimators.models.Gaussian` with the predicted points' moments."""

    moments: PredictedMoments | None = None


@dataclass(frozen=True)
class MomentSqrtGaussian(SqrtGaussian):
    """A :class:`~estimators.models.SqrtGaussian` with the predicted points' moments."""

    moments: PredictedMoments | None = None


def paper_moments(D: Array, w: Array, P: Array, noise_cov: Array | None = None
                  ) -> tuple[float, float, str | None]:
    r"""[Ding 2017]'s averaged :math:`(s, k) = (\sqrt N\phi_1, N\phi_2)` of the
    propagated deviations ``D`` (m, d) with weights ``w`` (m,) and predicted covariance
    ``P`` (d, d), plus the additive Gaussian noise ``noise_cov`` when the points do not
    carry it (module docstring); the third element is ``None`` or why there is no
    estimate (then ``s, k`` are NaN)."""
    W = w @ D**3
    Psi = w @ D**4
    if noise_cov is not None:
        q = np.diagonal(noise_cov)
        Psi = Psi + 6.0 * (w @ D**2) * q + 3.0 * q**2
    try:
        S = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        return np.nan, np.nan, "the predicted covariance has no Cholesky factor"
    c3, c4 = float(np.sum(S**3)), float(np.sum(S**4))
    if not (c3 != 0.0 and c4 > 0.0):
        return np.nan, np.nan, f"sum of the factor's cubes {c3:.3g} (fourth powers {c4:.3g})"
    with np.errstate(over="ignore", invalid="ignore"):
        s, k = float(np.sum(W)) / c3, float(np.sum(Psi)) / c4
    if not (np.isfinite(s) and np.isfinite(k)):
        return np.nan, np.nan, "the moment sums are not finite"
    return s, k, None


def _with_moments(belief: Belief, moments: PredictedMoments) -> Belief:
    if isinstance(belief, SqrtGaussian):
        return MomentSqrtGaussian(belief.mean, belief.sqrt, belief.space, moments)
    return MomentGaussian(belief.mean, belief.cov, belief.space, moments)


def predicted_belief(rule: Any, prior: Belief, predicted: Belief, D: Array, w: Array,
                     noise_cov: Array | None) -> Belief:
    """``predicted`` with the moments of its points for a predicted-moments HoMM ``rule``
    (guarded and counted, module docstring); unchanged for any other rule."""
    if not (isinstance(rule, HighOrderMoment) and rule.moments == "predicted"):
        return predicted
    before = getattr(prior, "moments", None)
    done, failed = (0, 0) if before is None else (before.predictions, before.fallbacks)
    s, k, why = paper_moments(D, w, predicted.cov, noise_cov)
    if why is None and not k > s * s:
        why = f"estimated kurtosis {k:.4g} is not above skewness² {s * s:.4g}"
    if why is None:
        m = PredictedMoments(s, k, (s, k), None, failed, done + 1)
    else:
        m = PredictedMoments(float(rule.skewness), float(rule.kurtosis), (s, k), why,
                             failed + 1, done + 1)
    return _with_moments(predicted, m)


def drawn_rule(rule: Any, belief: Belief, noise_dim: int = 0) -> Any:
    """The rule a draw from ``belief`` uses (:meth:`HighOrderMoment.for_draw`; any other
    rule as it is)."""
    return rule.for_draw(belief, noise_dim) if isinstance(rule, HighOrderMoment) else rule


def carry_update(prior: Belief, posterior: Belief) -> Belief:
    """The posterior with the prior's predicted moments, unchanged (module docstring)."""
    m = getattr(prior, "moments", None)
    return posterior if m is None else _with_moments(posterior, m)


def augmented_rule(n: int, m: int, skewness: float | tuple[float, ...] = 0.0,
                   kurtosis: float | tuple[float, ...] = 3.0) -> HighOrderMoment:
    r"""The noise-augmented set of [Ding 2017] eq. (22)-(23) as a rule for dimension ``n + m``.

    State axes (the first ``n``): moment-matched with ``skewness``/``kurtosis``.  Noise
    axes (the last ``m``): :math:`\pm\sqrt N e_j` with weight :math:`1/(2N)`,
    :math:`N = n + m`, i.e. skewness 0 and kurtosis :math:`N`.  Centre weight
    :math:`1 - \sum_{i \ge 1} w_i`.  Use it with a non-additive transition (the order
    of :func:`~estimators.sigma.draw`'s augmentation is state, then noise).
    """
    N = n + m
    skew = _per_axis(skewness, n, "skewness") + (0.0,) * m
    kurt = _per_axis(kurtosis, n, "kurtosis") + (float(N),) * m
    return HighOrderMoment(skew, kurt, name="high-order-moment-augmented")


def standardised_moments(samples: Array) -> tuple[tuple[float, ...], tuple[float, ...]]:
    r"""Per-axis skewness and kurtosis of samples whitened by their Cholesky factor.

    :math:`\xi = S^{-1}(x - \bar x)` with :math:`S S^\top` the sample covariance; returns
    :math:`(E\xi_j^3, E\xi_j^4)` per axis, the moments :class:`HighOrderMoment` matches
    along the columns of the same Cholesky factor.
    """
    x = np.asarray(samples, dtype=float)
    d = x - x.mean(axis=0)
    S = np.linalg.cholesky(d.T @ d / x.shape[0])
    xi = np.linalg.solve(S, d.T).T
    return (tuple(float(v) for v in np.mean(xi**3, axis=0)),
            tuple(float(v) for v in np.mean(xi**4, axis=0)))
