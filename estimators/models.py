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


class NoiseError(ValueError, ArithmeticError):
    """A noise covariance or factor that is not finite, square, symmetric and positive
    semi-definite (or a σ whose square under- or overflows).

    A ``ValueError`` for a library caller; also an ``ArithmeticError``, so a noise built
    from bad numbers inside a run ends that run as a counted divergence
    (:mod:`estimators.loop`) rather than escaping it."""


_SYM_RTOL = 1e-9
_FACTOR_RTOL = 1e-6


def _as_matrix(a: Any, what: str) -> Array:
    m = np.atleast_2d(np.asarray(a, dtype=float))
    if not np.isfinite(m).all():
        raise NoiseError(f"noise {what} is not finite")
    return m


def _check_symmetric(cov: Array) -> None:
    if cov.shape[-2] != cov.shape[-1]:
        raise NoiseError(f"noise covariance must be square, got shape {cov.shape}")
    scale = float(np.max(np.abs(cov), initial=0.0))
    if np.max(np.abs(cov - np.swapaxes(cov, -1, -2)), initial=0.0) > _SYM_RTOL * scale:
        raise NoiseError("noise covariance is not symmetric")
    diag = np.diagonal(cov, axis1=-2, axis2=-1)
    if (diag < 0.0).any():
        raise NoiseError(f"noise covariance has a negative variance ({float(diag.min()):.3e})")


def _psd_sqrt(cov: Array) -> Array:
    """A square factor of a symmetric ``cov``: Cholesky, or for a singular positive
    semi-definite matrix ``U Λ₊^{1/2}`` (eigenvalues down to ``-n ε λ_max`` count as 0)."""
    try:
        return chol(cov)
    except np.linalg.LinAlgError:
        pass
    lam, U = np.linalg.eigh(cov)
    top = np.max(np.abs(lam), axis=-1, initial=0.0)
    if np.any(lam.min(axis=-1, initial=0.0) < -cov.shape[-1] * np.finfo(float).eps * top):
        raise NoiseError(f"noise covariance is not positive semi-definite "
                         f"(eigenvalue {lam.min():.3e})") from None
    return U * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]


@dataclass(frozen=True)
class Noise:
    r"""A zero-mean Gaussian noise: covariance ``cov`` (d, d) and a factor ``sqrt`` (d, k)
    with :math:`\mathrm{cov} = S S^\top` (lower triangular from :meth:`from_cov` when the
    covariance is positive definite).

    Every constructor checks its input - finite, square, symmetric, positive
    semi-definite, ``cov`` equal to ``sqrt @ sqrt.T`` to a relative 1e-6 - and raises
    :class:`NoiseError` naming the fault; a filter never sees a NaN or infinite noise.
    A batch of noises (one per run of a batch, :mod:`estimators.batch`) has leading axes:
    ``cov`` (..., d, d), ``sqrt`` (..., d, k).
    """

    cov: Array
    sqrt: Array

    def __post_init__(self) -> None:
        cov, sqrt = _as_matrix(self.cov, "covariance"), _as_matrix(self.sqrt, "factor")
        _check_symmetric(cov)
        if sqrt.shape[-2] != cov.shape[-1]:
            raise NoiseError(f"noise factor has {sqrt.shape[-2]} rows for a "
                             f"{cov.shape[-1]}-dimensional covariance")
        implied = sqrt @ np.swapaxes(sqrt, -1, -2)
        scale = max(float(np.max(np.abs(cov), initial=0.0)),
                    float(np.max(np.abs(implied), initial=0.0)))
        if np.max(np.abs(implied - cov), initial=0.0) > _FACTOR_RTOL * scale:
            raise NoiseError("noise factor does not reproduce the covariance "
                             "(cov != sqrt @ sqrt.T)")
        object.__setattr__(self, "cov", cov)
        object.__setattr__(self, "sqrt", sqrt)

    @classmethod
    def from_cov(cls, cov: Array) -> Noise:
        """From a finite, symmetric, positive semi-definite covariance."""
        cov = _as_matrix(cov, "covariance")
        _check_symmetric(cov)
        return cls(cov, _psd_sqrt(cov))

    @classmethod
    def from_pd(cls, cov: Array) -> Noise | None:
        """From a (d, d) covariance that is positive definite: ``cov`` symmetrised and its
        Cholesky factor, or ``None`` when the factorisation fails (then take another
        constructor).  The checks of the others hold by construction - symmetric (made
        so), ``cov = L Lᵀ`` (Cholesky) - and the one left, finite, is made on ``cov``
        and ``L``.  The cheap constructor of a noise built afresh at every step."""
        cov = np.asarray(cov, dtype=float)
        if cov.ndim != 2 or cov.shape[0] != cov.shape[1]:
            raise NoiseError(f"noise covariance must be square, got shape {cov.shape}")
        cov = 0.5 * (cov + cov.T)
        try:
            L = np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            return None
        if not (np.isfinite(cov).all() and np.isfinite(L).all()):
            raise NoiseError("noise covariance is not finite")
        out = object.__new__(cls)
        object.__setattr__(out, "cov", cov)
        object.__setattr__(out, "sqrt", L)
        return out

    @classmethod
    def from_sigmas(cls, sigmas: Array) -> Noise:
        """Independent components with standard deviations ``sigmas`` (finite, >= 0, and
        each σ² a normal float: a σ > 0 whose square underflows is refused)."""
        s = np.atleast_1d(np.asarray(sigmas, dtype=float))
        if not np.isfinite(s).all():
            raise NoiseError("noise sigma is not finite")
        if (s < 0.0).any():
            raise NoiseError(f"noise sigma is negative ({float(s.min()):.3e})")
        with np.errstate(over="ignore", under="ignore"):
            var = s**2
        if not np.isfinite(var).all():
            raise NoiseError(f"noise sigma {float(s.max()):.3e} squares to infinity")
        tiny = (s > 0.0) & (var < np.finfo(float).tiny)
        if tiny.any():
            raise NoiseError(f"noise sigma {float(s[tiny].min()):.3e} squares to "
                             f"{float(var[tiny].min()):.3e} (underflow)")
        if s.ndim == 1:
            return cls(np.diag(var), np.diag(s))
        eye = np.eye(s.shape[-1])
        return cls(var[..., None] * eye, s[..., None] * eye)

    @classmethod
    def from_sqrt(cls, sqrt: Array) -> Noise:
        """From any finite factor ``S`` (d, k): ``cov = S Sᵀ``."""
        sqrt = _as_matrix(sqrt, "factor")
        with np.errstate(over="ignore", invalid="ignore"):
            cov = sqrt @ np.swapaxes(sqrt, -1, -2)
        if not np.isfinite(cov).all():
            raise NoiseError("noise factor squares to a non-finite covariance")
        return cls(0.5 * (cov + np.swapaxes(cov, -1, -2)), sqrt)

    @property
    def dim(self) -> int:
        return self.cov.shape[-1]


@dataclass(frozen=True)
class Gaussian:
    """Belief with dense covariance; ``mean`` in ambient, ``cov`` in tangent coordinates.

    A batch of beliefs (one per Monte Carlo run) has leading axes: ``mean`` (..., n),
    ``cov`` (..., d, d); every filter step accepts and returns such a batch
    (:mod:`estimators.batch`)."""

    mean: Array
    cov: Array
    space: Space

    @property
    def dim(self) -> int:
        return self.space.dim

    def cov_block(self, rows: Array) -> Array:
        """Covariance of the tangent coordinates ``rows`` (a square block of ``cov``)."""
        if self.cov.ndim == 2:
            return self.cov[np.ix_(rows, rows)]
        return self.cov[..., rows, :][..., rows]


@dataclass(frozen=True)
class SqrtGaussian:
    """Belief stored as a covariance factor only (``cov`` is derived on request); a batch
    has leading axes (``mean`` (..., n), ``sqrt`` (..., d, d))."""

    mean: Array
    sqrt: Array
    space: Space

    @property
    def cov(self) -> Array:
        return self.sqrt @ np.swapaxes(self.sqrt, -1, -2)

    @property
    def dim(self) -> int:
        return self.space.dim

    def cov_block(self, rows: Array) -> Array:
        """Covariance of the tangent coordinates ``rows``, from those rows of the
        factor only (the joint covariance is never formed)."""
        S = self.sqrt[..., rows, :]
        return S @ np.swapaxes(S, -1, -2)


Belief = Gaussian | SqrtGaussian


def _check_model(what: str, fn: Any, noise: Any, jacobian: Any) -> None:
    """A model's callables are callable and its noise is a :class:`Noise` (validated when
    it was made) or behaves as one (``dim``, ``cov``, ``sqrt``: e.g. a lazily formed noise)."""
    if not callable(fn):
        raise TypeError(f"{what} function must be callable, got {type(fn).__name__}")
    if jacobian is not None and not callable(jacobian):
        raise TypeError(f"{what} Jacobian must be callable or None")
    if not isinstance(noise, Noise) and not all(hasattr(noise, a) for a in ("dim", "cov", "sqrt")):
        raise TypeError(f"{what} noise must be a Noise, got {type(noise).__name__}")


@dataclass(frozen=True)
class Transition:
    r"""Motion model.

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
    moves : int or None
        A declaration: ``f`` computes the first ``moves`` coordinates (ambient and tangent
        alike) from those coordinates and the noise alone, and copies every later one, on
        which no noise acts (a static tail, e.g. a SLAM map: :math:`F = \mathrm{diag}(F_v,
        I)`, :math:`G = [G_v; 0]`).  The square-root sigma-point prediction and the EKF's
        then take structured steps (:mod:`estimators.structured`); ``None`` (the default):
        no declaration, the dense steps.
    """

    f: Callable[..., Array]
    noise: Noise
    additive: bool = True
    space: Space | None = None
    jacobian: Callable[..., Any] | None = None
    moves: int | None = None

    def __post_init__(self) -> None:
        _check_model("transition", self.f, self.noise, self.jacobian)
        if self.moves is not None and not (isinstance(self.moves, int) and self.moves >= 1):
            raise ValueError(f"transition moves must be a positive int or None, "
                             f"got {self.moves!r}")


@dataclass(frozen=True)
class Measurement:
    """Measurement model ``z = h(x) ⊞ v``, ``v ~ N(0, noise.cov)``.

    ``space`` defaults to :math:`\\mathbb{R}^{nz}`; ``jacobian(x) -> H`` (nz, d) optional.
    ``reads`` (a declaration, optional): the state coordinates ``h`` depends on (ambient and
    tangent alike; its Jacobian is zero elsewhere); the square-root sigma-point update and
    the EKF's then take structured steps (:mod:`estimators.structured`).  ``None``: no
    declaration, the dense steps.  ``selects`` (a declaration, with ``reads``):
    :math:`h(x) = x_{\\mathrm{reads}}` exactly, so the square-root sigma-point update is the
    Kalman update on those rows (no points drawn).
    """

    h: Callable[[Array], Array]
    noise: Noise
    space: Space = field(default=None)  # type: ignore[assignment]
    jacobian: Callable[[Array], Array] | None = None
    reads: tuple[int, ...] | None = None
    selects: bool = False

    def __post_init__(self) -> None:
        _check_model("measurement", self.h, self.noise, self.jacobian)
        if self.reads is not None:
            rows = tuple(int(r) for r in self.reads)
            if not rows or min(rows) < 0:
                raise ValueError(f"measurement reads must be non-empty rows >= 0, "
                                 f"got {self.reads!r}")
            object.__setattr__(self, "reads", rows)
        if self.selects and (self.reads is None or len(self.reads) != self.noise.dim):
            raise ValueError("a measurement that selects rows declares them (reads), one "
                             "per measured coordinate")
        if self.space is None:
            object.__setattr__(self, "space", Euclidean(self.noise.dim))
        elif self.space.dim != self.noise.dim:
            raise NoiseError(f"measurement noise is {self.noise.dim}-dimensional, its space "
                             f"{self.space.dim}-dimensional")


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
        return self.sqrt_cov @ np.swapaxes(self.sqrt_cov, -1, -2)
