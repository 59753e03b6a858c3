r"""Beliefs, noises and models: the values filters pass around.

Filters are functions of these values; none of them holds state between calls.

* :class:`Gaussian` - mean and dense covariance (EKF, CKF, UKF, CDKF).
* :class:`SqrtGaussian` - mean and a square factor :math:`S` with :math:`P = S S^\top`
  (lower triangular for the square-root filters, :math:`U\Sigma` for the SVD-CKF).
* :class:`Transition` - :math:`x_{k+1} = f(x_k, u_k) \boxplus w_k` (additive noise in the
  tangent space) or :math:`x_{k+1} = f(x_k, u_k, w_k)` (noise entering the model).
* :class:`Measurement` - :math:`z = h(x) \boxplus v`.

Models are vectorised over points: ``f`` maps ``(m, nx)`` to ``(m, nx')``, ``h`` maps
``(m, nx)`` to ``(m, nz)``.  Covariances live in tangent coordinates of the spaces.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .linalg import chol
from .spaces import Euclidean, Space

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Noise:
    """A zero-mean Gaussian noise: covariance ``cov`` and its lower factor ``sqrt``."""

    cov: Array
    sqrt: Array

    @classmethod
    def from_cov(cls, cov: Array) -> Noise:
        cov = np.atleast_2d(np.asarray(cov, dtype=float))
        return cls(cov, chol(cov))

    @classmethod
    def from_sigmas(cls, sigmas: Array) -> Noise:
        s = np.atleast_1d(np.asarray(sigmas, dtype=float))
        return cls(np.diag(s**2), np.diag(s))

    @classmethod
    def from_sqrt(cls, sqrt: Array) -> Noise:
        sqrt = np.atleast_2d(np.asarray(sqrt, dtype=float))
        return cls(sqrt @ sqrt.T, sqrt)

    @property
    def dim(self) -> int:
        return self.cov.shape[0]


@dataclass(frozen=True)
class Gaussian:
    """Belief with dense covariance; ``mean`` in ambient, ``cov`` in tangent coordinates."""

    mean: Array
    cov: Array
    space: Space

    @property
    def dim(self) -> int:
        return self.space.dim

    def cov_block(self, rows: Array) -> Array:
        """Covariance of the tangent coordinates ``rows`` (a square block of ``cov``)."""
        return self.cov[np.ix_(rows, rows)]


@dataclass(frozen=True)
class SqrtGaussian:
    """Belief stored as a covariance factor only (``cov`` is derived on request)."""

    mean: Array
    sqrt: Array
    space: Space

    @property
    def cov(self) -> Array:
        return self.sqrt @ self.sqrt.T

    @property
    def dim(self) -> int:
        return self.space.dim

    def cov_block(self, rows: Array) -> Array:
        """Covariance of the tangent coordinates ``rows``, from those rows of the
        factor only (the joint covariance is never formed)."""
        S = self.sqrt[rows]
        return S @ S.T


Belief = Gaussian | SqrtGaussian


@dataclass(frozen=True)
class Transition:
    """Motion model.

    Attributes
    ----------
    f : callable
        ``f(X, u)`` (additive) or ``f(X, u, W)`` (non-additive), points as rows.
    noise : Noise
        Additive: tangent-space noise of the output, shape (d', d').  Non-additive:
        the noise input ``W``'s distribution, shape (nw, nw).
    additive : bool
    space : Space or None
        Output space when it differs from the input belief's (augmentation);
        ``None`` keeps the belief's space.
    jacobian : callable or None
        ``jacobian(x, u) -> F`` (additive) or ``-> (F, G)`` (non-additive), in tangent
        coordinates; used by the EKF, which otherwise differentiates numerically.
    """

    f: Callable[..., Array]
    noise: Noise
    additive: bool = True
    space: Space | None = None
    jacobian: Callable[..., Any] | None = None


@dataclass(frozen=True)
class Measurement:
    """Measurement model ``z = h(x) ⊞ v``, ``v ~ N(0, noise.cov)``.

    ``space`` defaults to :math:`\\mathbb{R}^{nz}`; ``jacobian(x) -> H`` (nz, d) optional.
    """

    h: Callable[[Array], Array]
    noise: Noise
    space: Space = field(default=None)  # type: ignore[assignment]
    jacobian: Callable[[Array], Array] | None = None

    def __post_init__(self) -> None:
        if self.space is None:
            object.__setattr__(self, "space", Euclidean(self.noise.dim))


@dataclass(frozen=True)
class Innovation:
    r"""What an update saw: innovation :math:`\nu = z \boxminus \hat z`, the lower factor of
    its covariance, and the normalised innovation squared :math:`\nu^\top S^{-1}\nu`.

    ``hinf_fallback`` is True when an H∞ update (:mod:`estimators.hinf`) found its
    Riccati existence condition violated and fell back to the Kalman update.
    """

    nu: Array
    sqrt_cov: Array
    nis: float
    hinf_fallback: bool = False

    @property
    def cov(self) -> Array:
        return self.sqrt_cov @ self.sqrt_cov.T
