r"""Partitioned (block-local) steps: sigma points or Jacobians only over the blocks a step
touches, for states laid out as one vehicle block followed by equal landmark blocks.

A joint state :math:`s = [v;\ m_1; \dots; m_N]` (vehicle first) is described by a
:class:`BlockLayout`: the vehicle has :math:`a_v` ambient and :math:`n_v` tangent
coordinates, every landmark :math:`a_l` and :math:`n_l` (a quaternion vehicle
``[p, q, b]`` has :math:`a_v = 10`, :math:`n_v = 9`).  Means are sliced by ambient
columns, covariances and factors by tangent rows.  The filter gives the steps
(:meth:`ExtendedKalmanFilter.partitioned <estimators.ekf.ExtendedKalmanFilter.partitioned>`,
:meth:`SigmaPointFilter.partitioned <estimators.sigma.SigmaPointFilter.partitioned>` for
the square-root form; :data:`PARTITIONED_FILTERS`); other filters raise
:class:`NoPartitionedModeError`.  ``steps = filt.partitioned(layout)`` has

* ``steps.predict(belief, transition, u)`` - the vehicle block and the control noise
  (``transition`` moves the vehicle alone: state space ``layout.space_of(0)``);
* ``steps.update(belief, slots, measurement, z) -> (belief, innovation)`` - the vehicle
  and the landmarks in ``slots`` (``measurement`` is of the block ``[v; m_slots]``, space
  ``layout.space_of(len(slots))``);
* ``steps.augment(belief, transition, u)`` - appended rows (``transition`` maps the
  vehicle alone to ``[v; new landmarks]`` with the observation noise as an input).

The rest of the joint state is carried by the exact linear relations that the block's
linearisation implies.  The joint lower-triangular factor :math:`S` (:math:`P = SS^\top`)
is changed by a QR of the few rows that change and rank-:math:`k` Cholesky
updates/downdates (:func:`~estimators.linalg.chol_update_sweep`); the joint covariance is
never formed and never re-factorised.  Points, weights and covariance factors come from
the filter's own rule (:func:`estimators.sigma.draw`, ``rule.factor``), so the SRUKF's
signed centre term and the SRCDKF's divided differences are carried as in joint mode.

Notation
    :math:`S = \begin{bmatrix} S_v & 0 \\ S_{mv} & S_{mm}\end{bmatrix}` with :math:`S_v`
    (:math:`n_v\times n_v`) the vehicle block.  Because :math:`S` is lower triangular and
    the vehicle comes first, :math:`S_v` *is* a factor of the vehicle marginal
    :math:`P_{vv}`.  For a block :math:`a` with factor :math:`S_a` the rule's unit points
    :math:`\xi_i` give the input deviations :math:`S_a\xi_i`; the rule's factor of the
    stacked deviations ``rule.factor([S_a ξ_i, y_i ⊟ ȳ])`` is :math:`[C_a; C_y]` (plus a
    signed centre column :math:`s_0 c_0` for the unscented rule).  The rule is linear in the
    deviations, so :math:`C_a = S_a U` with :math:`U` = ``rule.factor(ξ).C`` and
    :math:`UU^\top = I` for the cubature, unscented and central-difference rules.

Statistical linearisation (all three steps)
    .. math::

        G = C_y U^\top,\qquad E = C_y - G U,

    so that :math:`P_{ya} = C_y C_a^\top = G S_a^\top`, the regression matrix is
    :math:`A = P_{ya} P_{aa}^{-1} = G S_a^{-1}` (:math:`A S_a = G`, no inverse needed, and
    it stays defined for a singular :math:`S_a`), and the residual covariance is
    :math:`P_{yy} - A P_{aa} A^\top = E E^\top + s_0 c_0 c_0^\top` (:math:`I - U^\top U`
    is a projector).  For the EKF :math:`G = J S_a` with the model Jacobian :math:`J`
    (:func:`~estimators.ekf.linearise_transition`, the EKF's own selection) and :math:`E = 0`.

Prediction (block :math:`a = [v; w]`, :math:`w` the control noise, :math:`S_a =
\mathrm{blkdiag}(S_v, S_w)`, :math:`G = [G_v, G_w]`)

    The new vehicle is :math:`v' = \bar y \boxplus (A_v (v \boxminus \hat v) + e)` with
    :math:`e` independent of the map, so :math:`P_{v'v'} = C_yC_y^\top (+ s_0 c_0c_0^\top)
    (+Q)` and :math:`P_{v'm} = A_v P_{vm}`, :math:`P_{mm}` unchanged.  In factor form the
    new rows of the vehicle are :math:`[G_v \mid 0 \mid T]` with :math:`TT^\top =
    G_wG_w^\top + EE^\top (+ c_0c_0^\top)(+Q)` (``tria``) and the map rows are
    :math:`[S_{mv} \mid S_{mm} \mid 0]`.  One QR of the :math:`2n_v\times n_v` matrix
    :math:`[G_v, T]^\top = Q R` gives

    .. math::

        S_v' = R^\top,\qquad S_{mv}' = S_{mv} Q_{11},\qquad
        S_{mm}' S_{mm}'^\top = S_{mm}S_{mm}^\top + (S_{mv} K)(S_{mv} K)^\top,\
        K = \mathrm{tria}(Q_{12}),

    a rank-:math:`n_v` Cholesky *update* of :math:`S_{mm}` (:math:`Q_{11} = M^\top` with
    :math:`M = S_v'^{-1} A_v S_v`, :math:`Q_{12}Q_{12}^\top = I - M^\top M \succeq 0`):
    :math:`O(n^2)`.  The update is deferred: the prediction returns the wide factor
    :math:`[S' \mid X]` (:math:`P' = S'S'^\top + XX^\top`, :math:`X = [0; S_{mv}K]`, zero
    in the vehicle rows, so later predictions leave it alone) and the next update folds
    it into its downdate in one signed sweep (:func:`~estimators.linalg.chol_update_mixed`);
    after :data:`MAX_PENDING` deferred columns a prediction folds them itself (LAPACK
    ``dtpqrt``).  A negative centre weight (:math:`s_0 < 0`) ends with a rank-one
    downdate of the whole factor by :math:`[c_0; 0]`.  EKF: :math:`P_{v'v'} = FP_{vv}F^\top
    + GQ_wG^\top`, :math:`P_{v'm} = FP_{vm}`.

Update (block :math:`s` = vehicle and observed landmarks, tangent rows :math:`r`,
ambient columns :math:`c`)

    The block factor comes from a thin QR of the block's rows of the joint factor,
    :math:`S_{r,:}^\top = \Omega S_s^\top` (:math:`\Omega^\top\Omega = I`), so
    :math:`P_{x,s} = S\,\Omega S_s^\top`.  With the block's points about :math:`x_c`,
    :math:`S_{zz} = \mathrm{tria}([C_z, S_R]) (\pm c_0)` and

    .. math::

        P_{xz} = P_{x,s} P_{ss}^{-1} P_{sz} = S\,\Omega\,U C_z^\top,\qquad
        \bar U = P_{xz} S_{zz}^{-\top},\qquad
        \hat x^+ = \hat x \boxplus \bar U S_{zz}^{-1}\nu,\qquad
        S^+ S^{+\top} = SS^\top - \bar U\bar U^\top,

    a rank-:math:`n_z` Cholesky *downdate* of the whole factor (with any deferred
    prediction columns folded in the same sweep): :math:`O(n_z n^2)`.  For the
    EKF :math:`P_{xz} = P_{:,r} H_s^\top` and
    :math:`P^+ = P - K P_{xz}^\top - P_{xz}K^\top + K P_{zz} K^\top` (the Joseph form,
    expanded; :math:`O(n_z n^2)`).

Augmentation (block :math:`a = [v; w]`, :math:`w` the observation noise, new landmarks
:math:`l = g(v, z + w)`)

    :math:`P_{l,x} = A_v P_{v,x} = G_v S_{:,1:n_v}^\top`, hence the appended rows of the
    factor are

    .. math::

        [\,P_{l,x} S^{-\top},\ \ \mathrm{chol}(P_{ll} - P_{l,x}P^{-1}P_{x,l})\,]
        = [\,G_v\ 0 \cdots 0,\ \ \mathrm{tria}([G_w, E])\ (\pm c_0)\,]:

    :math:`O(n)`; the old rows are untouched.  EKF: :math:`P_{l,x} = F_l P_{v,x}`,
    :math:`P_{ll} = F_l P_{vv} F_l^\top + G_l Q_w G_l^\top`.

Agreement with ``joint`` mode
    Every local step is the filter's own step on the block's marginal, carried to the rest
    of the state by the regression :math:`A = P_{x,a} P_{aa}^{-1}`.  The EKF's Jacobians see
    only the block anyway, so EKF local = joint to rounding on any model.  On models linear
    in the whole state both modes are the Kalman filter.  With the lower-triangular joint
    factor, joint-mode points along the landmark columns do not move the vehicle, so for
    the central-difference rule (step :math:`h` independent of the dimension) joint and
    local *prediction and augmentation* coincide on any model, and updates coincide when
    the measurement is linear in the landmarks (the vehicle columns of :math:`S_s` are
    those of :math:`S`; along the others the divided differences are exact); on a
    measurement nonlinear in the landmarks joint mode sees the block through the
    :math:`n`-column rows :math:`S_{r,:}`, local mode through the square root :math:`S_s`,
    and the divided differences depend on the square root.  The cubature and unscented
    rules differ in every step unless the block is the whole state: joint mode applies the
    rule in the full dimension, spreading the block's points by :math:`\sqrt{n}`
    (cubature) instead of :math:`\sqrt{n_a}` - a different quadrature of the same
    nonlinearity that agrees with the local one only to the rule's degree (millimetres on
    the bailey world; see ``tests/estimators/test_partitioned*.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Protocol

import numpy as np

from .blocks import (  # noqa: F401  (this module's public names)
    PARTITIONED_FILTERS,
    BlockLayout,
    NoPartitionedModeError,
    _block_index,
    refuse_partitioned,
)
from .finite import require_finite, require_finite_input
from .linalg import (
    Array,
    NotPositiveDefiniteError,
    chol,
    chol_update_mixed,
    chol_update_sweep,
    kalman_gain,
    qr_complete,
    solve_lower,
    tria,
)
from .linearise import linearise_measurement, linearise_transition
from .models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from .rules import Factor, PointRule
from .sigma_points import SqrtMethod, draw, factorise


class _Linearising(Protocol):
    eps: float  # what the EKF steps read from their filter: the finite-difference step


class _PointDrawing(Protocol):
    rule: PointRule  # what the sigma-point steps read from their filter
    sqrt_method: SqrtMethod


__all__ = [
    "MAX_PENDING", "PARTITIONED_FILTERS", "BlockLayout", "EkfBlockSteps",
    "NoPartitionedModeError", "PartitionedSteps", "SqrtSigmaBlockSteps", "refuse_partitioned",
]

#: At most this many deferred positive columns ride along before a prediction folds them.
MAX_PENDING = 12


class PartitionedSteps(Protocol):
    """What ``filt.partitioned(layout)`` returns (see the module docstring)."""

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Belief: ...

    def update(self, belief: Belief, slots: Array, model: Measurement, z: Array
               ) -> tuple[Belief, Innovation]: ...

    def augment(self, belief: Belief, model: Transition, u: Any = None) -> Belief: ...


def _need_noise_input(model: Transition) -> None:
    if model.additive:
        raise ValueError("local augmentation needs the observation noise as a model input "
                         "(a non-additive transition)")


# --------------------------------------------------------------------------- EKF

@dataclass(frozen=True)
class EkfBlockSteps:
    """The EKF's partitioned steps (dense covariance; Jacobians of the block only, by the
    EKF's own selection :func:`~estimators.ekf.linearise_transition` /
    :func:`~estimators.ekf.linearise_measurement`)."""

    filt: _Linearising
    layout: BlockLayout

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> Gaussian:
        """:math:`P_{v'v'} = FP_{vv}F^\\top + Q`, :math:`P_{v'm} = FP_{vm}`, map unchanged."""
        lay = self.layout
        av, nv = lay.vehicle_ambient, lay.vehicle_dim
        vspace = lay.space_of(0)
        P = belief.cov
        x = belief.mean
        F, Gw, y = linearise_transition(model, x[:av], u, vspace, model.space or vspace,
                                        self.filt.eps)
        Q = model.noise.cov if Gw is None else Gw @ model.noise.cov @ Gw.T
        Pn = P.copy()
        Pvv = F @ P[:nv, :nv] @ F.T + Q
        Pn[:nv, :nv] = 0.5 * (Pvv + Pvv.T)
        Pn[:nv, nv:] = F @ P[:nv, nv:]
        Pn[nv:, :nv] = Pn[:nv, nv:].T
        return Gaussian(np.concatenate([y, x[av:]]), Pn, belief.space)

    def update(self, belief: Belief, slots: Array, model: Measurement, z: Array
               ) -> tuple[Gaussian, Innovation]:
        """:math:`P_{xz} = P_{:,r}H_s^\\top`, Joseph form expanded (module docstring)."""
        lay = self.layout
        rows = lay.rows(slots)
        x, P = belief.mean, belief.cov
        require_finite("measurement", z)
        H, zhat = linearise_measurement(model, x[lay.cols(slots)], lay.space_of(len(slots)),
                                        self.filt.eps)
        nu = model.space.local(zhat, np.asarray(z, dtype=float))
        Pxz = P[:, rows] @ H.T
        Pzz = H @ Pxz[rows] + model.noise.cov
        Szz = chol(0.5 * (Pzz + Pzz.T))
        K = kalman_gain(Pxz, Szz)
        KPxz = K @ Pxz.T
        Pn = P - KPxz - KPxz.T + K @ Pzz @ K.T
        w = solve_lower(Szz, nu)
        post = Gaussian(belief.space.retract(x, K @ nu), 0.5 * (Pn + Pn.T), belief.space)
        return post, Innovation(nu, Szz, float(w @ w))

    def augment(self, belief: Belief, model: Transition, u: Any = None) -> Gaussian:
        """Appended rows :math:`P_{l,x} = F_l P_{v,x}`, :math:`P_{ll} = F_lP_{vv}F_l^\\top
        + G_lQ_wG_l^\\top`."""
        _need_noise_input(model)
        lay = self.layout
        av, nv = lay.vehicle_ambient, lay.vehicle_dim
        vspace = lay.space_of(0)
        x, P = belief.mean, belief.cov
        n = belief.dim
        F, Gw, y = linearise_transition(model, x[:av], u, vspace, model.space or vspace,
                                        self.filt.eps)
        Jv = F[nv:]
        Q = model.noise.cov if Gw is None else Gw[nv:] @ model.noise.cov @ Gw[nv:].T
        m = Jv.shape[0]
        Pn = np.zeros((n + m, n + m))
        Pn[:n, :n] = P
        Plx = Jv @ P[:nv]
        Pn[n:, :n] = Plx
        Pn[:n, n:] = Plx.T
        Pll = Jv @ P[:nv, :nv] @ Jv.T + Q
        Pn[n:, n:] = 0.5 * (Pll + Pll.T)
        k = m // lay.landmark_dim
        return Gaussian(np.concatenate([x, y[av:]]), Pn,
                        lay.space_of(lay.n_landmarks(n) + k))


# --------------------------------------------------------------------------- sigma points

@lru_cache(maxsize=256)
def _unit_factor(rule: PointRule, k: int) -> Array:
    """``U`` with ``rule.factor(S ξ).C = S U`` for a ``k``-dimensional block (``UUᵀ = I``)."""
    xi, _ = rule.points(k)
    U = np.array(rule.factor(np.asarray(xi)).C)
    U.setflags(write=False)
    return U


def _regression(rule: PointRule, dA: Array, dY: Array
                ) -> tuple[Array, Array, Array | None, float]:
    """Statistical linearisation of ``y`` on the block ``a``: ``(G, E, c0_y, sign)``."""
    ka = dA.shape[1]
    fac = rule.factor(np.hstack([dA, dY]))
    Cy = fac.C[ka:]
    U = _unit_factor(rule, ka)
    G = Cy @ U.T
    E = Cy - G @ U
    c0 = None if fac.c0 is None else fac.c0[ka:]
    return G, E, c0, fac.sign


def _sign_fix(Q: Array, R: Array) -> tuple[Array, Array]:
    d = np.where(np.diagonal(R) < 0.0, -1.0, 1.0)
    return Q * d, R * d[:, None]


@dataclass(frozen=True)
class SqrtSigmaBlockSteps:
    """The square-root sigma-point filters' partitioned steps (lower-triangular factor,
    possibly wide with deferred prediction columns; module docstring)."""

    filt: _PointDrawing
    layout: BlockLayout

    def _vehicle_points(self, belief: Belief, model: Transition, noise: bool, u: Any
                        ) -> tuple[Array, Array, Array, Array]:
        require_finite_input(u)
        return draw(self.filt.rule, self.layout.vehicle(belief), model.noise if noise else None,
                    self.filt.sqrt_method)

    def predict(self, belief: Belief, model: Transition, u: Any = None) -> SqrtGaussian:
        """Vehicle rows by one QR, map rows by a deferred rank-:math:`n_v` update."""
        lay = self.layout
        av, nv = lay.vehicle_ambient, lay.vehicle_dim
        x, S = belief.mean, belief.sqrt
        X, W, dX, wm = self._vehicle_points(belief, model, not model.additive, u)
        Y = model.f(X, u) if model.additive else model.f(X, u, W)
        require_finite("transition output", Y)
        out = model.space or lay.space_of(0)
        ybar = out.mean(Y, wm)
        G, E, c0, sign = _regression(self.filt.rule, np.hstack([dX, W]), out.local(ybar, Y))
        extra = [G[:, nv:], E]
        if model.additive:
            extra.append(model.noise.sqrt)
        if c0 is not None and sign > 0:
            extra.append(c0[:, None])
        T = tria(np.hstack(extra))
        Q, R = qr_complete(np.hstack([G[:, :nv], T]).T)                     # [G_v, T]ᵀ = QR
        n = belief.dim
        pend = S[nv:, n:]                                     # positive columns not yet folded
        fold = n > nv and pend.shape[1] + nv > MAX_PENDING
        wide = n > nv and not fold
        Sn = np.empty((n, n + pend.shape[1] + nv)) if wide else np.empty((n, n))
        Sn[:nv] = 0.0
        Sn[:nv, :nv] = R.T
        if n > nv:
            Smv = S[nv:, :nv]
            Sn[nv:, :nv] = Smv @ Q[:nv, :nv]
            X = Smv @ tria(Q[:nv, nv:])                       # S_mm' S_mm'ᵀ = S_mm S_mmᵀ + XXᵀ
            if wide:   # defer the rank-nv update: fold it into the next update's downdate
                Sn[nv:, nv:n] = S[nv:, nv:n]
                Sn[nv:, n:-nv] = pend
                Sn[nv:, -nv:] = X
            else:
                Sn[nv:, nv:] = chol_update_sweep(S[nv:, nv:n], np.hstack([pend, X]), 1.0)
        if c0 is not None and sign < 0:
            v = np.zeros(n)
            v[:nv] = c0
            Sn = chol_update_mixed(Sn[:, :n], Sn[:, n:], v)
        return SqrtGaussian(np.concatenate([ybar, x[av:]]), Sn, belief.space)

    def update(self, belief: Belief, slots: Array, model: Measurement, z: Array
               ) -> tuple[SqrtGaussian, Innovation]:
        """Block points from a thin QR of the block's rows; one downdate of the factor."""
        lay = self.layout
        rule = self.filt.rule
        rows = lay.rows(slots)
        x, S = belief.mean, belief.sqrt
        n = belief.dim
        top = int(rows.max()) + 1
        cols = np.r_[0:top, n:S.shape[1]]                       # pending columns too
        Om, R = np.linalg.qr(S[rows][:, cols].T)                # S_r = Ω S_sᵀ (thin QR)
        Om, R = _sign_fix(Om, R)
        if (k := len(rows) - R.shape[0]) > 0:  # fewer columns than rows (a repeated slot)
            Om = np.hstack([Om, np.zeros((len(Om), k))])
            R = np.vstack([R, np.zeros((k, len(rows)))])
        bs = SqrtGaussian(x[lay.cols(slots)], R.T, lay.space_of(len(slots)))
        require_finite("measurement", z)
        X, _, dX, wm = draw(rule, bs, None, self.filt.sqrt_method)
        Z = model.h(X)
        require_finite("measurement model output", Z)
        zspace = model.space
        zhat = zspace.mean(Z, wm)
        ks = len(rows)
        fac = rule.factor(np.hstack([dX, zspace.local(zhat, Z)]))
        Cz = fac.C[ks:]
        c0z = None if fac.c0 is None else fac.c0[ks:]
        Szz = factorise("sqrt", Factor(Cz, c0z, fac.sign), model.noise.sqrt)
        if not np.all(np.diagonal(Szz) > 0.0):
            raise NotPositiveDefiniteError("innovation covariance is singular")
        V = Om @ (_unit_factor(rule, ks) @ Cz.T)               # P_xz = S[:, cols] V
        Pxz = S[:, :top] @ V[:top]
        if S.shape[1] > n:
            Pxz += S[:, n:] @ V[top:]
        Ubar = solve_lower(Szz, Pxz.T).T                        # P_xz S_zz^{-T}
        nu = zspace.local(zhat, np.asarray(z, dtype=float))
        w = solve_lower(Szz, nu)
        mean = belief.space.retract(x, Ubar @ w)
        if S.shape[1] > n:   # the pending update and this downdate in one sweep
            post = chol_update_mixed(S[:, :n], S[:, n:], Ubar)
        else:
            post = chol_update_sweep(S, Ubar, -1.0)
        return SqrtGaussian(mean, post, belief.space), Innovation(nu, Szz, float(w @ w))

    def augment(self, belief: Belief, model: Transition, u: Any = None) -> SqrtGaussian:
        """Appended rows ``[G_v 0 ⋯ 0, tria([G_w, E]) (± c0)]``; old rows untouched."""
        _need_noise_input(model)
        lay = self.layout
        av, nv = lay.vehicle_ambient, lay.vehicle_dim
        x, S = belief.mean, belief.sqrt
        n = belief.dim
        X, W, dX, wm = self._vehicle_points(belief, model, True, u)
        Yall = model.f(X, u, W)
        require_finite("transition output", Yall)
        k = (Yall.shape[1] - av) // lay.landmark_ambient
        new_space = lay.space_of(k)
        # the new landmarks' own coordinates: local charts of the block output, minus vehicle
        ybar_all = new_space.mean(Yall, wm)
        dY = new_space.local(ybar_all, Yall)[:, nv:]
        G, E, c0, sign = _regression(self.filt.rule, np.hstack([dX, W]), dY)
        extra = [G[:, nv:], E]
        if c0 is not None and sign > 0:
            extra.append(c0[:, None])
        Lll = tria(np.hstack(extra))
        if c0 is not None and sign < 0:
            Lll = chol_update_sweep(Lll, c0, -1.0)
        m = dY.shape[1]
        p = S.shape[1] - n                                      # pending columns stay last
        Sn = np.zeros((n + m, n + m + p))
        Sn[:n, :n] = S[:, :n]
        Sn[:n, n + m:] = S[:, n:]
        Sn[n:, :nv] = G[:, :nv]
        Sn[n:, n:n + m] = Lll
        return SqrtGaussian(np.concatenate([x, ybar_all[av:]]), Sn,
                            lay.space_of(lay.n_landmarks(n) + k))
