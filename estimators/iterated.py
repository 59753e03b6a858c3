r"""Iterated measurement updates: the iterated EKF and the iterated posterior
linearisation (sigma-point) update, on any space.

Both work in the tangent coordinates :math:`\delta` of the prior :math:`N(\hat x, P)`
(:math:`x = \hat x \boxplus \delta`), with the measurement :math:`g(\delta) = h(\hat x
\boxplus \delta)` and its residual :math:`r(\delta) = z \boxminus g(\delta)`.

Iterated EKF (Bell & Cathey 1993: a Gauss-Newton method on the MAP cost)
    .. math::

        J(\delta) = \tfrac12 r(\delta)^\top R^{-1} r(\delta) + \tfrac12 \delta^\top P^{-1}\delta,
        \qquad
        \delta_{i+1} = K_i\,\big(r(\delta_i) + G_i \delta_i\big),\quad
        K_i = P G_i^\top (G_i P G_i^\top + R)^{-1},

    with :math:`G_i = \partial g/\partial\delta` at :math:`\delta_i`: the model's analytic
    Jacobian at :math:`\hat x \boxplus \delta_i` where it has one and the space is flat
    (its chart Jacobian is the identity) and at :math:`\delta = 0`; otherwise central
    differences through the space, so it holds on a group or a quaternion chart.
    *Step control*: a step that does not lower :math:`J` is halved (up to 10 times) before
    it is taken; the iteration stops after ``iterations`` steps or when the step is below
    ``tolerance`` (in the whitened norm :math:`\|\Delta\delta\|_{P^{-1}}`).  The posterior is
    :math:`\hat x \boxplus \delta^*` with the Joseph-form covariance of the last
    linearisation, :math:`(I - K G)P(I - KG)^\top + K R K^\top`.  With ``iterations = 1`` it
    is the EKF update exactly; on a linear model every iteration returns the Kalman update.

Iterated posterior linearisation (García-Fernández, Svensson, Morelande & Särkkä 2015)
    Iteration :math:`i` draws the rule's sigma points from the current posterior
    approximation :math:`N(\delta_i, P_i)`, fits the statistical linear regression
    :math:`g(\delta) \approx A_i \delta + b_i + e`, :math:`e \sim N(0, \Omega_i)`,

    .. math::

        A_i = C_{z\delta} C_{\delta\delta}^{-1},\quad b_i = \bar z - A_i\bar\delta,\quad
        \Omega_i = C_{zz} - A_i C_{\delta\delta} A_i^\top,

    and updates the *prior* with it: :math:`K = P A_i^\top (A_i P A_i^\top + \Omega_i +
    R)^{-1}`, :math:`\delta_{i+1} = K (z \boxminus b_i)`, :math:`P_{i+1} = P - K S K^\top`
    (square-root: :math:`\mathrm{tria}([S_P - K A_i S_P,\ K S_{\Omega + R}])`).  Only the
    positive semi-definite part of :math:`\Omega_i` is kept (:func:`_residual_factor`).  The first
    iteration draws from the prior, where this is exactly the one-pass sigma-point update;
    on a linear model :math:`A = H`, :math:`\Omega = 0` and it is the Kalman update.  It stops
    after ``iterations`` or when the mean moves less than ``tolerance`` (whitened).

The points of later iterations are drawn in the prior's chart (a posterior covariance in
the coordinates :math:`\delta`), which is exact on flat spaces and first-order on groups.
The time update is the one-pass filter's.  Neither has block-local (partitioned) steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, NoReturn

import numpy as np

from .ekf import ExtendedKalmanFilter, ekf_update
from .finite import require_finite
from .linalg import Array, chol, kalman_gain, nis_of, solve_lower, tria
from .linearise import linearise_measurement
from .models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian
from .rules import PointRule
from .sigma import SigmaPointFilter
from .sigma_points import Form, psd_factor
from .spaces import Angle, Euclidean, Product, Space, Wrapped

_HALVINGS = 10


def _check(iterations: int, tolerance: float) -> None:
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
    if not (isinstance(tolerance, int | float) and tolerance >= 0.0):
        raise ValueError(f"tolerance must be a number >= 0, got {tolerance!r}")


def _g(model: Measurement, space: Space, x: Array, delta: Array) -> Array:
    """``h(x ⊞ δ)`` for deltas (m, d) -> (m, nz)."""
    return model.h(space.retract(x, np.atleast_2d(delta)))


def _chart_jacobian(model: Measurement, space: Space, x: Array, delta: Array,
                    eps: float = 1e-6) -> tuple[Array, Array]:
    """:math:`G = \\partial h(x \\boxplus \\delta)/\\partial\\delta` at ``delta`` (central
    differences, all in one batch) and :math:`g(\\delta)`."""
    d = delta.shape[0]
    steps = np.vstack([eps * np.eye(d), -eps * np.eye(d)]) + delta
    Z = _g(model, space, x, np.vstack([delta, steps]))
    z0 = Z[0]
    dZ = model.space.local(z0, Z[1:])
    require_finite("measurement model output", Z)
    return ((dZ[:d] - dZ[d:]) / (2.0 * eps)).T, z0


def _flat(space: Space) -> bool:
    """A space whose retraction is addition (angles wrapped): its chart Jacobian is the
    identity, so the model's own Jacobian at ``x ⊞ δ`` is the chart's."""
    if isinstance(space, Product):
        return all(_flat(p) for p in space.parts)
    return isinstance(space, Euclidean | Angle | Wrapped)


def iekf_update(belief: Gaussian, model: Measurement, z: Array, iterations: int,
                tolerance: float) -> tuple[Gaussian, Innovation]:
    """The iterated EKF update (module docstring); ``iterations = 1`` is
    :func:`~estimators.ekf.ekf_update`."""
    if iterations == 1:
        return ekf_update(belief, model, z)
    require_finite("measurement", z)
    x, P, space = belief.mean, belief.cov, belief.space
    z = np.asarray(z, dtype=float)
    R = model.noise.cov
    L = chol(0.5 * (P + P.T))
    Rl = chol(R)
    d = belief.dim

    def cost(delta: Array, r: Array) -> float:
        a, b = solve_lower(Rl, r), solve_lower(L, delta)
        return float(a @ a + b @ b)

    delta = np.zeros(d)
    G, z0 = linearise_measurement(model, x, space)
    r = model.space.local(z0, z)
    J = cost(delta, r)
    inn = None
    for _ in range(iterations):
        S = G @ P @ G.T + R
        Szz = chol(0.5 * (S + S.T))
        K = kalman_gain(P @ G.T, Szz)
        if inn is None:  # the innovation of the first linearisation (the EKF's)
            w = solve_lower(Szz, r)
            inn = Innovation(r, Szz, float(w @ w))
        target = K @ (r + G @ delta)
        step = target - delta
        moved = False
        for _h in range(_HALVINGS + 1):
            cand = delta + step
            zc = _g(model, space, x, cand)[0]
            rc = model.space.local(zc, z)
            Jc = cost(cand, rc)
            if Jc <= J:
                moved = True
                break
            step = 0.5 * step
        if not moved:
            break
        size = float(np.linalg.norm(solve_lower(L, step)))
        delta, r, J = cand, rc, Jc
        if model.jacobian is not None and _flat(space):
            G = linearise_measurement(model, space.retract(x, delta), space)[0]
        else:
            G, _ = _chart_jacobian(model, space, x, delta)
        if size <= tolerance:
            break
    S = G @ P @ G.T + R
    K = kalman_gain(P @ G.T, chol(0.5 * (S + S.T)))
    A = np.eye(d) - K @ G
    Pn = A @ P @ A.T + K @ R @ K.T
    post = Gaussian(space.retract(x, delta), 0.5 * (Pn + Pn.T), space)
    return post, inn  # type: ignore[return-value]


@dataclass(frozen=True)
class IteratedEKF(ExtendedKalmanFilter):
    """The iterated EKF (module docstring): the EKF's prediction, an iterated update."""

    name: str = "iekf"
    iterations: int = 5
    tolerance: float = 1e-9
    supports_partitioned: ClassVar[bool] = False
    batched: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check(self.iterations, self.tolerance)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Gaussian, Innovation]:
        if np.ndim(belief.mean) > 1:
            raise ValueError("the iterated EKF has no batched update; run it per run")
        b = belief if isinstance(belief, Gaussian) else Gaussian(belief.mean, belief.cov,
                                                                  belief.space)
        return iekf_update(b, model, z, self.iterations, self.tolerance)

    def partitioned(self, layout: Any) -> NoReturn:
        from .partitioned import refuse_partitioned

        refuse_partitioned(self.name)


def _residual_factor(Om: Array) -> Array:
    """A factor of the regression residual Ω projected on the positive semi-definite
    matrices (its negative eigenvalues set to 0).  Ω is zero for a linear model (round-off
    then makes it slightly indefinite) and can be indefinite in earnest for a rule with a
    negative centre weight (the unscented set with κ < 3 − n... or α = 1, κ = 0, β = 2):
    the regression's second-order term is then not a covariance, and only its positive
    part is kept."""
    lam, U = np.linalg.eigh(Om)
    return U * np.sqrt(np.clip(lam, 0.0, None))


def iplf_update(rule: PointRule, form: Form, belief: Belief, model: Measurement, z: Array,
                iterations: int, tolerance: float) -> tuple[Belief, Innovation]:
    """The iterated posterior linearisation update (module docstring); its first iteration
    is the one-pass sigma-point update."""
    require_finite("measurement", z)
    x, space, d = belief.mean, belief.space, belief.dim
    z = np.asarray(z, dtype=float)
    Sp = belief.sqrt if isinstance(belief, SqrtGaussian) else psd_factor(belief.cov)
    Rs = model.noise.sqrt
    xi, wm = rule.points(d)
    mean_i, S_i = np.zeros(d), Sp
    Lp = tria(Sp)  # lower factor of P, to whiten the steps
    inn: Innovation | None = None
    Sn = Sp
    for it in range(iterations):
        dpts = mean_i + xi @ S_i.T  # (m, d): points of N(δ_i, P_i) in the prior chart
        Z = _g(model, space, x, dpts)
        require_finite("measurement model output", Z)
        zbar = model.space.mean(Z, wm)
        dbar = wm @ dpts
        fac = rule.factor(np.hstack([dpts - dbar, model.space.local(zbar, Z)]))
        C = fac.C @ fac.C.T
        if fac.c0 is not None:
            C = C + fac.sign * np.outer(fac.c0, fac.c0)
        Cdd, Czd, Czz = C[:d, :d], C[d:, :d], C[d:, d:]
        A = np.linalg.solve(Cdd, Czd.T).T  # C_zδ C_δδ⁻¹ (C_δδ = P_i to round-off)
        Om = Czz - A @ Cdd @ A.T
        Om = 0.5 * (Om + Om.T)
        # the innovation about the linearised prediction A·0 + b = zbar − A δ̄
        zlin = model.space.retract(zbar, -(A @ dbar))
        nu = model.space.local(zlin, z)
        SoR = tria(np.hstack([_residual_factor(Om), Rs]))  # factor of Ω + R
        Szz = tria(np.hstack([A @ Sp, SoR]))                # of A P Aᵀ + Ω + R
        if not np.all(np.diagonal(Szz) > 0.0):
            raise np.linalg.LinAlgError("innovation covariance is singular")
        K = kalman_gain(Sp @ (A @ Sp).T, Szz)
        w = solve_lower(Szz, nu)
        if inn is None:
            inn = Innovation(nu, Szz, nis_of(w))
        new_mean = K @ nu
        Sn = tria(np.hstack([Sp - K @ A @ Sp, K @ SoR]))
        step = float(np.linalg.norm(solve_lower(Lp, new_mean - mean_i))) if it else np.inf
        mean_i, S_i = new_mean, Sn
        if step <= tolerance:
            break
    post_mean = space.retract(x, mean_i)
    if form == "dense":
        return Gaussian(post_mean, Sn @ Sn.T, space), inn  # type: ignore[return-value]
    return SqrtGaussian(post_mean, Sn, space), inn  # type: ignore[return-value]


@dataclass(frozen=True)
class IteratedSigmaPointFilter(SigmaPointFilter):
    """A sigma-point filter with the iterated posterior linearisation update (module
    docstring); prediction and settings as its one-pass twin."""

    iterations: int = 5
    tolerance: float = 1e-9
    batched: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check(self.iterations, self.tolerance)

    def update(self, belief: Belief, model: Measurement, z: Array
               ) -> tuple[Belief, Innovation]:
        if np.ndim(belief.mean) > 1:
            raise ValueError("the iterated sigma-point update has no batched form; run it "
                             "per run")
        return iplf_update(self.rule, self.form, belief, model, z, self.iterations,
                           self.tolerance)

    @property
    def supports_partitioned(self) -> bool:  # type: ignore[override]
        return False

    def partitioned(self, layout: Any) -> NoReturn:  # type: ignore[override]
        from .partitioned import refuse_partitioned

        refuse_partitioned(self.name)

    @property
    def twin(self) -> SigmaPointFilter:
        """The one-pass filter (same rule and form)."""
        return SigmaPointFilter(self.name, self.rule, self.form, self.sqrt_method)


__all__ = ["IteratedEKF", "IteratedSigmaPointFilter", "iekf_update", "iplf_update"]
