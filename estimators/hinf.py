r"""Sigma-point H∞ filters: the square-root cubature H∞ filter (SR-CH∞KF, [Spin SR-CH∞KF])
and the unscented H∞ filter (UT-H∞, [Wu-Wang 2014]), with the Riccati existence check.

Both papers pair a sigma-point time update with the *a-posteriori* (central) H∞
measurement update of a linear system with estimated quantity :math:`z = L x`, here
:math:`L = I`.  The papers print the update in the augmented ("Krein") arrangement
([Spin SR-CH∞KF] eq. 27-32, [Wu-Wang 2014] eq. 11-12; both garbled in the text); what is implemented
is the following reconstruction.

Statistical linearisation
-------------------------
From the points drawn from the predicted belief :math:`(\hat x, P)`, the update
computes (exactly as :func:`~estimators.sigma.sigma_update`) the cross covariance
:math:`P_{xz}` and the innovation covariance :math:`P_{zz} = C_z C_z^\top + R`.  Define

.. math::

    \tilde H = P_{xz}^\top P^{-1}, \qquad
    \tilde R = P_{zz} - \tilde H P \tilde H^\top ,

so that :math:`P_{xz} = P\tilde H^\top` and :math:`P_{zz} = \tilde H P \tilde H^\top +
\tilde R` hold exactly.  For a linear :math:`h` (and any rule exact to second order)
:math:`\tilde H = H` and :math:`\tilde R = R`; for a nonlinear :math:`h`,
:math:`\tilde R` also carries the linearisation error (Sibley et al.'s approximation,
[Spin SR-CH∞KF] eq. 28-29, made exact).  Using :math:`\tilde R` rather than :math:`R` is what
makes the filter reduce *exactly* to its Kalman twin as :math:`\gamma \to \infty` on a
nonlinear model.

Update
------
Gain and mean are the Kalman ones ([Spin SR-CH∞KF] eq. 26/32 and [Wu-Wang 2014]'s last step use the
predicted :math:`P` in the gain):

.. math::

    K = P_{xz} P_{zz}^{-1}, \qquad \hat x^+ = \hat x \boxplus K\,(z \boxminus \hat z).

The covariance bound is the H∞ Riccati update in information form,

.. math::

    P^+ = \big[P^{-1} + \tilde H^\top \tilde R^{-1} \tilde H - \gamma^{-2} I\big]^{-1}
        = \big[P_{KF}^{-1} - \gamma^{-2} I\big]^{-1},
    \qquad P_{KF} = P - K P_{zz} K^\top ,

where :math:`P_{KF} = (P^{-1} + \tilde H^\top\tilde R^{-1}\tilde H)^{-1}` is the sigma-point
Kalman posterior (Woodbury).  By the matrix inversion lemma this equals the papers'
augmented form

.. math::

    P^+ = P - \begin{bmatrix} P_{xz} & P \end{bmatrix} R_e^{-1}
              \begin{bmatrix} P_{xz}^\top \\ P \end{bmatrix},\qquad
    R_e = \begin{bmatrix} P_{zz} & P_{xz}^\top \\ P_{xz} & P - \gamma^2 I \end{bmatrix}
        = \begin{bmatrix} \tilde R & 0 \\ 0 & -\gamma^2 I\end{bmatrix}
          + \begin{bmatrix}\tilde H \\ I\end{bmatrix} P
            \begin{bmatrix}\tilde H^\top & I\end{bmatrix}.

(Simon's a-priori form uses :math:`K = P^+ \tilde H^\top \tilde R^{-1}` instead; it is
not what the two papers print and is not implemented.)  The papers' "error limiting
parameter" :math:`\kappa` ([Spin SR-CH∞KF]) is :math:`\gamma` here; [Spin SR-CH∞KF] eq. 25 prints
:math:`\kappa^2` where :math:`\kappa^{-2}` belongs (its text says a larger :math:`\kappa`
brings the filter closer to the Kalman filter, which only the inverse satisfies).

Existence (Riccati) condition
-----------------------------
The update exists iff the posterior information matrix is positive definite,

.. math::

    \Xi = P^{-1} + \tilde H^\top \tilde R^{-1} \tilde H - \gamma^{-2} I \succ 0
    \iff \lambda_{\min}(P^{-1} + \tilde H^\top \tilde R^{-1} \tilde H) > \gamma^{-2}
    \iff \lambda_{\max}(P_{KF}) < \gamma^2 ,

with :math:`\lambda_{\min}(\Xi) = 1/\lambda_{\max}(P_{KF}) - \gamma^{-2}`.  It is
evaluated from the update's moments before any H∞ posterior is formed.  When it fails,
``on_failure="raise"`` raises :class:`RiccatiConditionError`; ``on_failure="kalman"``
returns the ordinary Kalman update for that step with
``Innovation.hinf_fallback = True`` (callers count these; nothing is silent).

Choosing γ
----------
:math:`\gamma^{-2} I` is taken out of the information matrix at *every* update, in every
direction.  Where the measurements carry little information per step (a scalar
measurement of a 2-state, a direction observable only as the geometry changes) that
loss compounds over many updates and the bound grows until the condition fails, so
:math:`\gamma` has to be chosen for the update rate, not only for the size of
:math:`P` (``benchmarks/robustness.py --factor 1``: at 10 Hz over 875 updates on the
[Spin SR-CH∞KF] problem, :math:`\gamma = 1` rad diverged, with the condition failing in 9 % of
the updates, although :math:`\lambda_{\max}(P) \approx 0.003\ \mathrm{rad}^2`;
:math:`\gamma \ge 1.5` was stable).
A finite :math:`\gamma` also enlarges the gain: it weights measurements *more* than the
Kalman filter does.

Forms
-----
* ``"sqrt"`` (SR-CH∞KF): the SRCKF measurement update gives the Kalman factor
  :math:`S_{KF} = \mathrm{tria}([C_x - K C_z,\ K S_R])`.  The posterior information
  matrix whitened by that factor, :math:`S_{KF}^\top \Xi S_{KF} = I - \gamma^{-2}
  S_{KF}^\top S_{KF} = L L^\top`, is Cholesky-factored, and
  :math:`S^+ = \mathrm{tria}(S_{KF} L^{-\top})` (since
  :math:`P^+ = \Xi^{-1} = S_{KF} (L L^\top)^{-1} S_{KF}^\top`).  A failed Cholesky counts
  as a violated condition.
* ``"dense"`` (UT-H∞): :math:`P^+ = P_{KF} + P_{KF}(\gamma^2 I - P_{KF})^{-1} P_{KF}`
  (Woodbury form of the same inverse; the correction is :math:`O(\gamma^{-2})`).
* ``"svd"``: as ``"sqrt"`` with the factor re-made by an SVD instead of ``tria``.

The time update is the rule's sigma-point prediction, unchanged
(:func:`~estimators.sigma.sigma_predict`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar, Literal, NoReturn

import numpy as np

from .linalg import Array, NotPositiveDefiniteError, chol, solve_lower, svd_factor, swap, tria
from .models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from .rules import PointRule
from .sigma import Form, SigmaPointFilter, SqrtMethod, sigma_update
from .spaces import Space

if TYPE_CHECKING:
    from .partitioned import BlockLayout

OnFailure = Literal["raise", "kalman"]

__all__ = [
    "MIN_GAMMA",
    "HInfinityFilter",
    "OnFailure",
    "RiccatiConditionError",
    "hinf_posterior",
    "hinf_update",
    "riccati_min_eigenvalue",
]


class RiccatiConditionError(ArithmeticError):
    r"""The H∞ existence condition :math:`P^{-1} + \tilde H^\top \tilde R^{-1}\tilde H -
    \gamma^{-2} I \succ 0` failed.

    Attributes
    ----------
    gamma : float
    min_eigenvalue : float
        Smallest eigenvalue of that matrix (:math:`\le 0`, or barely positive when the
        factorisation failed on round-off).
    """

    def __init__(self, gamma: float, min_eigenvalue: float):
        self.gamma = float(gamma)
        self.min_eigenvalue = float(min_eigenvalue)
        super().__init__(
            f"H-infinity Riccati condition violated for gamma={self.gamma:.6g}: smallest "
            f"eigenvalue of P^-1 + H'R^-1 H - gamma^-2 I is {self.min_eigenvalue:.6e} "
            f"(needs > 0; raise gamma or use on_failure='kalman')")


MIN_GAMMA = 1.0 / math.sqrt(float(np.finfo(float).max))
"""The smallest bound γ whose 1/γ² is a finite number (about 7.5e-155): the update
subtracts γ⁻² I from the information matrix."""


def _check_gamma(gamma: float) -> None:
    if isinstance(gamma, bool) or not isinstance(gamma, int | float) or math.isnan(gamma):
        raise ValueError(f"gamma must be a number, got {gamma!r}")
    if not gamma >= MIN_GAMMA:
        raise ValueError(f"gamma must be at least {MIN_GAMMA:.3g} (1/gamma**2 must be finite), "
                         f"got {gamma!r}")


def riccati_min_eigenvalue(form: Form, kalman_posterior: Array, gamma: float) -> float:
    r"""Smallest eigenvalue of :math:`\Xi = P_{KF}^{-1} - \gamma^{-2} I`.

    Parameters
    ----------
    form : ``"dense"`` (``kalman_posterior`` is :math:`P_{KF}`) or ``"sqrt"``/``"svd"``
        (it is a square factor :math:`S_{KF}`).
    gamma : float
        The H∞ bound; ``inf`` gives :math:`1/\lambda_{\max}(P_{KF})`.

    Returns
    -------
    float
        :math:`\min_i (1/\lambda_i - \gamma^{-2})` over the eigenvalues
        :math:`\lambda_i \neq 0` of :math:`P_{KF}` (a zero eigenvalue is infinite
        information); ``inf`` if :math:`P_{KF} = 0`.  Negative when the condition fails,
        including when a dense :math:`P_{KF}` has a negative eigenvalue.
    """
    _check_gamma(gamma)
    if form == "dense":
        lam = np.linalg.eigvalsh(0.5 * (kalman_posterior + swap(kalman_posterior)))
    else:
        lam = np.linalg.svd(kalman_posterior, compute_uv=False) ** 2
    if lam.ndim > 1:  # a batch: one value per member
        with np.errstate(divide="ignore"):
            inv = np.where(lam != 0.0, 1.0 / np.where(lam != 0.0, lam, 1.0), np.inf)
        return np.min(inv, axis=-1) - 1.0 / gamma**2
    lam = lam[lam != 0.0]
    if lam.size == 0:
        return float("inf")
    return float(np.min(1.0 / lam) - 1.0 / gamma**2)


def hinf_posterior(form: Form, kalman_posterior: Array, gamma: float) -> Array:
    r"""The H∞ bound :math:`P^+ = (P_{KF}^{-1} - \gamma^{-2} I)^{-1}` (or a factor of it).

    Raises :class:`RiccatiConditionError` when the existence condition fails (checked
    first; a Cholesky failure on round-off at the boundary counts as a failure too).
    """
    xi_min = riccati_min_eigenvalue(form, kalman_posterior, gamma)
    if not np.all(xi_min > 0.0):
        raise RiccatiConditionError(gamma, float(np.min(xi_min)))
    if np.isinf(gamma):
        return kalman_posterior
    n = kalman_posterior.shape[-1]
    try:
        if form == "dense":
            P = kalman_posterior
            Lg = chol(gamma**2 * np.eye(n) - P)
            W = solve_lower(Lg, P)  # Lg⁻¹ P:  P (γ²I − P)⁻¹ P = Wᵀ W
            out = P + swap(W) @ W
            return 0.5 * (out + swap(out))
        S = kalman_posterior
        M = np.eye(n) - (swap(S) @ S) / gamma**2
        L = chol(0.5 * (M + swap(M)))
    except NotPositiveDefiniteError as exc:
        raise RiccatiConditionError(gamma, float(np.min(xi_min))) from exc
    F = swap(solve_lower(L, swap(S)))  # S L⁻ᵀ
    return svd_factor(F) if form == "svd" else tria(F)


def hinf_update(rule: PointRule, form: Form, belief: Belief, model: Measurement, z: Array,
                gamma: float, on_failure: OnFailure = "raise",
                method: SqrtMethod = "cholesky") -> tuple[Belief, Innovation]:
    """The sigma-point H∞ measurement update (see the module docstring).

    Returns the H∞ belief (Kalman mean, H∞ covariance bound) and the innovation; when
    the Riccati condition fails and ``on_failure == "kalman"``, the Kalman belief and an
    innovation with ``hinf_fallback=True``.
    """
    if on_failure not in ("raise", "kalman"):
        raise ValueError(f"on_failure must be 'raise' or 'kalman', got {on_failure!r}")
    _check_gamma(gamma)
    post, inn = sigma_update(rule, form, belief, model, z, method)
    kalman = post.cov if form == "dense" else post.sqrt  # type: ignore[union-attr]
    if kalman.ndim > 2:
        return _hinf_batch(form, post, inn, kalman, gamma, on_failure)
    try:
        bound = hinf_posterior(form, kalman, gamma)
    except RiccatiConditionError:
        if on_failure == "raise":
            raise
        return post, replace(inn, hinf_fallback=True)
    if form == "dense":
        return Gaussian(post.mean, bound, post.space), inn
    return SqrtGaussian(post.mean, bound, post.space), inn


def _hinf_batch(form: Form, post: Belief, inn: Innovation, kalman: Array, gamma: float,
                on_failure: OnFailure) -> tuple[Belief, Innovation]:
    """:func:`hinf_update`'s bound for a batch: each member whose Riccati condition fails
    keeps its Kalman posterior and is flagged in ``hinf_fallback`` (an array), or the call
    raises (``on_failure="raise"``)."""
    ok = np.asarray(riccati_min_eigenvalue(form, kalman, gamma) > 0.0)
    if not ok.all() and on_failure == "raise":
        raise RiccatiConditionError(gamma, float(np.min(riccati_min_eigenvalue(form, kalman,
                                                                                gamma))))
    bound = np.array(kalman, copy=True)
    if ok.any():
        bound[ok] = hinf_posterior(form, kalman[ok], gamma)
    inn = replace(inn, hinf_fallback=~ok)
    if form == "dense":
        return Gaussian(post.mean, bound, post.space), inn
    return SqrtGaussian(post.mean, bound, post.space), inn


@dataclass(frozen=True)
class HInfinityFilter:
    """A sigma-point H∞ filter: a rule, a covariance form, the bound γ and a failure policy.

    Same interface as :class:`~estimators.sigma.SigmaPointFilter` (pure ``init``,
    ``predict``, ``update``).  ``HInfinityFilter("srchinf", Cubature(), "sqrt", gamma)``
    is the SR-CH∞KF; ``HInfinityFilter("uthinf", Unscented(), "dense", gamma)`` the
    UT-H∞ filter.
    """

    name: str
    rule: PointRule
    form: Form = "sqrt"
    gamma: float = 5.0
    on_failure: OnFailure = "raise"
    sqrt_method: SqrtMethod = "cholesky"
    #: No block-local steps: the H∞ bound acts on the whole joint covariance.
    supports_partitioned: ClassVar[bool] = False
    #: Its steps accept a batch of beliefs (leading axis: the runs; :mod:`estimators.batch`).
    batched: ClassVar[bool] = True

    def __post_init__(self) -> None:
        _check_gamma(self.gamma)
        if self.on_failure not in ("raise", "kalman"):
            raise ValueError(f"on_failure must be 'raise' or 'kalman', got {self.on_failure!r}")

    @property
    def kalman(self) -> SigmaPointFilter:
        """The Kalman twin (same rule and form; the γ → ∞ limit)."""
        return SigmaPointFilter(self.name, self.rule, self.form, self.sqrt_method)

    def init(self, mean: Array, space: Space, cov: Array | None = None,
             sqrt: Array | None = None) -> Belief:
        return self.kalman.init(mean, space, cov, sqrt)

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Belief:
        return self.kalman.predict(belief, model, u)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Belief, Innovation]:
        return hinf_update(self.rule, self.form, belief, model, z, self.gamma,
                           self.on_failure, self.sqrt_method)

    def partitioned(self, layout: BlockLayout) -> NoReturn:
        """Raises :class:`~estimators.partitioned.NoPartitionedModeError` (no local mode)."""
        from .partitioned import refuse_partitioned

        refuse_partitioned(self.name)
