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

import numpy as np

from .linalg import Array
from .rules import Factor, signed_factor

__all__ = ["HighOrderMoment", "augmented_rule", "standardised_moments"]


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
    """

    skewness: float | tuple[float, ...] = 0.0
    kurtosis: float | tuple[float, ...] = 3.0
    name: str = "high-order-moment"

    @property
    def settings(self) -> dict[str, float | str]:
        return {"skewness": self.skewness, "kurtosis": self.kurtosis}  # type: ignore[dict-item]

    def points(self, n: int) -> tuple[Array, Array]:
        return _homm_points(_per_axis(self.skewness, n, "skewness"),
                            _per_axis(self.kurtosis, n, "kurtosis"))

    def factor(self, D: Array) -> Factor:
        """:math:`C = [\\sqrt{w_i} D_i]_{i \\ge 1}`; centre :math:`\\sqrt{|w_0|} D_0`, signed."""
        n = (D.shape[-2] - 1) // 2
        return signed_factor(D, self.points(n)[1])


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
