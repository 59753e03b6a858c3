r"""Sigma-point rules as values.

A rule gives unit points :math:`\xi_i` and mean weights :math:`w_i` for an
``n``-dimensional standard normal, and turns the deviations :math:`D_i` of the
propagated points from their mean into a covariance factor: a matrix :math:`C`
and an optional signed rank-one term, with

.. math::  P = C C^\top + s_0\, c_0 c_0^\top .

The same factor feeds the dense (:math:`P`), square-root (``tria``) and SVD forms,
so one predict/update pair serves every rule.  Points are rows: ``xi`` has shape
``(m, n)``, ``D`` has shape ``(m, d)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Factor:
    """A covariance factor: ``P = C Cᵀ + sign · c0 c0ᵀ`` (``c0`` may be ``None``)."""

    C: Array
    c0: Array | None = None
    sign: float = 1.0


def signed_factor(D: Array, w: Array) -> Factor:
    """The factor of deviations ``D`` (..., 2n+1, d) with weights ``w`` (2n+1,) whose centre
    weight ``w[0]`` may be negative: ``C = [√w_i D_i]_{i≥1}``, centre ``√|w_0| D_0`` signed."""
    C = np.swapaxes(D[..., 1:, :], -1, -2) * np.sqrt(w[1:])
    if w[0] == 0.0:
        return Factor(C)
    return Factor(C, np.sqrt(abs(w[0])) * D[..., 0, :], float(np.sign(w[0])))


def _readonly(*arrays: Array) -> tuple[Array, ...]:
    for a in arrays:
        a.setflags(write=False)
    return arrays


@lru_cache(maxsize=256)
def _symmetric_points(n: int, spread: float, centre: bool) -> Array:
    eye = spread * np.eye(n)
    rows = [np.zeros((1, n))] if centre else []
    return _readonly(np.vstack(rows + [eye, -eye]))[0]


@dataclass(frozen=True)
class Cubature:
    r"""Third-degree spherical-radial cubature: :math:`2n` points :math:`\pm\sqrt{n}\,e_i`,
    weights :math:`1/2n` (Arasaratnam & Haykin 2009, eq. 26)."""

    name: str = "cubature"

    @property
    def settings(self) -> dict[str, float | str]:
        return {}

    def points(self, n: int) -> tuple[Array, Array]:
        return _symmetric_points(n, float(np.sqrt(n)), False), _cubature_weights(n)

    def factor(self, D: Array) -> Factor:
        return Factor(np.swapaxes(D, -1, -2) * np.sqrt(1.0 / D.shape[-2]))


@lru_cache(maxsize=256)
def _cubature_weights(n: int) -> Array:
    return _readonly(np.full(2 * n, 1.0 / (2 * n)))[0]


JULIER_KAPPA = "3-n"
"""``Unscented(kappa=JULIER_KAPPA)``: κ = 3 − n in every dimension (Julier & Uhlmann's
original set, whose fourth moments along the axes are the Gaussian's)."""


@dataclass(frozen=True)
class Unscented:
    r"""Scaled unscented transform (Wan & van der Merwe), :math:`2n+1` points.

    .. math::

        \lambda = \alpha^2 (n + \kappa) - n,\quad
        \xi_0 = 0,\ \xi_{\pm i} = \pm\sqrt{n+\lambda}\, e_i,\quad
        w^m_0 = \tfrac{\lambda}{n+\lambda},\ w^c_0 = w^m_0 + 1 - \alpha^2 + \beta,\
        w_{\pm i} = \tfrac{1}{2(n+\lambda)} .

    ``kappa`` is a number or ``"3-n"`` (:data:`JULIER_KAPPA`: κ = 3 − n for whatever
    dimension the rule is asked for).  A negative :math:`w^c_0` is carried as a signed
    rank-one term (a Cholesky downdate in the square-root form).

    **α = 1, β = 2, κ = 0 (the defaults) is the cubature rule in disguise**: λ = 0, so the
    points are the cubature points :math:`\pm\sqrt n\, e_i` with the cubature weights
    :math:`1/2n`, plus a centre point of mean weight 0 and covariance weight 2 - a CKF
    with one changed weight (:attr:`cubature_equivalent`).  Compare a UKF with a CKF only
    at another setting (e.g. κ = 3 − n, or the scaled set α = 1e-3, β = 2, κ = 0).
    """

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float | str = 0.0
    name: str = "unscented"

    def __post_init__(self) -> None:
        for key in ("alpha", "beta"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
                raise ValueError(f"unscented {key} must be a finite number, got {v!r}")
        if not self.alpha > 0.0:
            raise ValueError(f"unscented alpha must be positive, got {self.alpha!r}")
        k = self.kappa
        if isinstance(k, str):
            if k != JULIER_KAPPA:
                raise ValueError(f"unscented kappa must be a number or {JULIER_KAPPA!r}, got {k!r}")
        elif isinstance(k, bool) or not isinstance(k, int | float) or not np.isfinite(k):
            raise ValueError(f"unscented kappa must be a finite number or {JULIER_KAPPA!r}, "
                             f"got {k!r}")

    def kappa_for(self, n: int) -> float:
        """κ in dimension ``n`` (``3 - n`` for :data:`JULIER_KAPPA`)."""
        return 3.0 - n if isinstance(self.kappa, str) else float(self.kappa)

    @property
    def cubature_equivalent(self) -> bool:
        """True when λ = 0 in every dimension (α = 1, κ = 0): the cubature points and mean
        weights plus a zero-weight centre (see the class docstring)."""
        return self.alpha == 1.0 and not isinstance(self.kappa, str) and self.kappa == 0.0

    @property
    def settings(self) -> dict[str, float | str]:
        return {"alpha": self.alpha, "beta": self.beta, "kappa": self.kappa}

    def _lam(self, n: int) -> float:
        lam = self.alpha**2 * (n + self.kappa_for(n)) - n
        if not n + lam > 0.0:
            raise ValueError(f"unscented rule needs n + lambda > 0 (n={n}, lambda={lam})")
        return lam

    def points(self, n: int) -> tuple[Array, Array]:
        lam = self._lam(n)
        return _symmetric_points(n, float(np.sqrt(n + lam)), True), _ut_weights(n, lam, 0.0)

    def weights_c(self, n: int) -> Array:
        lam = self._lam(n)
        return _ut_weights(n, lam, 1.0 - self.alpha**2 + self.beta)

    def factor(self, D: Array) -> Factor:
        n = (D.shape[-2] - 1) // 2
        return signed_factor(D, self.weights_c(n))


@lru_cache(maxsize=256)
def _ut_weights(n: int, lam: float, extra: float) -> Array:
    w = np.full(2 * n + 1, 1.0 / (2.0 * (n + lam)))
    w[0] = lam / (n + lam) + extra
    return _readonly(w)[0]


@dataclass(frozen=True)
class CentralDifference:
    r"""Stirling interpolation (central-difference / divided-difference filter).

    Points :math:`\xi_0 = 0,\ \xi_{\pm i} = \pm h e_i`; mean weights
    :math:`w_0 = (h^2 - n)/h^2`, :math:`w_{\pm i} = 1/(2h^2)`.  The covariance is not
    a weighted outer product but the first- and second-order divided differences
    (Nørgaard, Poulsen & Ravn 2000):

    .. math::

        C = \Big[\tfrac{D_{+i} - D_{-i}}{2h}\Big]_{i}\ \Big|\
            \Big[\tfrac{\sqrt{h^2-1}}{2h^2}(D_{+i} + D_{-i} - 2D_0)\Big]_{i} .

    :math:`h = \sqrt{3}` is optimal for Gaussian priors.
    """

    h: float = float(np.sqrt(3.0))
    name: str = "central-difference"

    def __post_init__(self) -> None:
        h = self.h
        if isinstance(h, bool) or not isinstance(h, int | float) or not (np.isfinite(h)
                                                                         and h > 1.0):
            raise ValueError(f"central-difference h must be a finite number above 1, got {h!r}")

    @property
    def settings(self) -> dict[str, float | str]:
        return {"h": self.h}

    def points(self, n: int) -> tuple[Array, Array]:
        return _symmetric_points(n, self.h, True), _cd_weights(n, self.h)

    def factor(self, D: Array) -> Factor:
        n = (D.shape[-2] - 1) // 2
        h = self.h
        plus, minus = D[..., 1:n + 1, :], D[..., n + 1:, :]
        first = (plus - minus) / (2.0 * h)
        second = (plus + minus - 2.0 * D[..., :1, :]) * (np.sqrt(h * h - 1.0) / (2.0 * h * h))
        return Factor(np.swapaxes(np.concatenate([first, second], axis=-2), -1, -2))


@lru_cache(maxsize=256)
def _cd_weights(n: int, h: float) -> Array:
    w = np.full(2 * n + 1, 1.0 / (2.0 * h * h))
    w[0] = (h * h - n) / (h * h)
    return _readonly(w)[0]


PointRule = Cubature | Unscented | CentralDifference
