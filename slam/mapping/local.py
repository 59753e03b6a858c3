r"""Block-local SLAM steps: sigma points only over the blocks a step touches.

In ``joint`` mode (:mod:`slam.mapping.joint`) every predict, update and augmentation draws sigma
points over the whole joint state :math:`s = [v;\ m_1; \dots; m_N]` (vehicle first).
In ``local`` mode a step draws points only over the block it touches - the vehicle and
the control noise for a prediction, the vehicle and the observed landmarks for an update,
the vehicle and the observation noise for an augmentation - and carries the rest of the
joint state by the exact linear relations that the block's statistical linearisation
implies.  The joint lower-triangular factor :math:`S` (:math:`P = SS^\top`) is changed by
a QR of the few rows that change and rank-:math:`k` Cholesky updates/downdates
(:func:`estimators.linalg.chol_update_sweep`); the joint covariance is never formed and
never re-factorised.  Points, weights and covariance factors come from the filter's own
rule (:func:`estimators.sigma.draw`, ``rule.factor``), so the SRUKF's signed centre term
and the SRCDKF's divided differences are carried exactly as in joint mode.

Notation
    :math:`S = \begin{bmatrix} S_v & 0 \\ S_{mv} & S_{mm}\end{bmatrix}` with :math:`S_v`
    (:math:`n_v\times n_v`) the vehicle block.  Because :math:`S` is lower triangular and
    the vehicle comes first, :math:`S_v` *is* a factor of the vehicle marginal
    :math:`P_{vv}`.  For a block :math:`a` with factor :math:`S_a` the rule's unit points
    :math:`\xi_i` give the input deviations :math:`S_a\xi_i`; the rule's factor of the
    stacked deviations ``rule.factor([S_a ξ_i, y_i - ȳ])`` is :math:`[C_a; C_y]` (plus a
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
    is a projector).  For the EKF :math:`G = J S_a` with the model Jacobian :math:`J` and
    :math:`E = 0`.

Prediction (block :math:`a = [v; w]`, :math:`w` the control noise, :math:`S_a =
\mathrm{blkdiag}(S_v, S_w)`, :math:`G = [G_v, G_w]`)
    The new vehicle is :math:`v' = \bar y + A_v (v - \hat v) + e` with :math:`e` independent
    of the map, so :math:`P_{v'v'} = C_yC_y^\top (+ s_0 c_0c_0^\top) (+Q)` and
    :math:`P_{v'm} = A_v P_{vm}`, :math:`P_{mm}` unchanged.  In factor form the new rows of
    the vehicle are :math:`[G_v \mid 0 \mid T]` with :math:`TT^\top = G_wG_w^\top + EE^\top
    (+ c_0c_0^\top)(+Q)` (``tria``) and the map rows are :math:`[S_{mv} \mid S_{mm} \mid 0]`.
    One QR of the :math:`2n_v\times n_v` matrix :math:`[G_v, T]^\top = Q R` gives

    .. math::

        S_v' = R^\top,\qquad S_{mv}' = S_{mv} Q_{11},\qquad
        S_{mm}' S_{mm}'^\top = S_{mm}S_{mm}^\top + (S_{mv} K)(S_{mv} K)^\top,\
        K = \mathrm{tria}(Q_{12}),

    a rank-:math:`n_v` Cholesky *update* of :math:`S_{mm}` (:math:`Q_{11} = M^\top` with
    :math:`M = S_v'^{-1} A_v S_v`, :math:`Q_{12}Q_{12}^\top = I - M^\top M \succeq 0`):
    :math:`O(n^2)`.  The update is deferred: the prediction returns the wide factor
    :math:`[S' \mid X]` (:math:`P' = S'S'^\top + XX^\top`, :math:`X = [0; S_{mv}K]`, zero
    in the vehicle rows, so later predictions leave it alone) and the next update folds
    it into its downdate in one signed sweep
    (:func:`~estimators.linalg.chol_update_mixed`); after ``MAX_PENDING`` deferred
    columns a prediction folds them itself (LAPACK ``dtpqrt``).  A negative centre weight
    (:math:`s_0 < 0`) ends with a rank-one downdate of the whole factor by
    :math:`[c_0; 0]`.

Update (block :math:`s` = vehicle and observed landmarks, rows :math:`r`)
    The block factor comes from a thin QR of the block's rows of the joint factor,
    :math:`S_{r,:}^\top = \Omega S_s^\top` (:math:`\Omega^\top\Omega = I`), so
    :math:`P_{x,s} = S\,\Omega S_s^\top`.  With the block's points,
    :math:`S_{zz} = \mathrm{tria}([C_z, S_R]) (\pm c_0)` and

    .. math::

        P_{xz} = P_{x,s} P_{ss}^{-1} P_{sz} = S\,\Omega\,U C_z^\top,\qquad
        \bar U = P_{xz} S_{zz}^{-\top},\qquad
        \hat x^+ = \hat x \boxplus \bar U S_{zz}^{-1}\nu,\qquad
        S^+ S^{+\top} = SS^\top - \bar U\bar U^\top,

    a rank-:math:`n_z` Cholesky *downdate* of the whole factor (with any deferred
    prediction columns folded in the same sweep): :math:`O(n_z n^2)`.  For the
    EKF :math:`P_{xz} = P_{:,s} H_s^\top` and
    :math:`P^+ = P - K P_{xz}^\top - P_{xz}K^\top + K P_{zz} K^\top` (the Joseph form,
    expanded; :math:`O(n_z n^2)`).

Augmentation (block :math:`a = [v; w]`, :math:`w` the observation noise, new landmarks
:math:`l = g(v, z + w)`)
    :math:`P_{l,x} = A_v P_{v,x} = G_v S_{:,1:n_v}^\top`, hence the appended rows of the
    factor are

    .. math::

        [\,P_{l,x} S^{-\top},\ \ \mathrm{chol}(P_{ll} - P_{l,x}P^{-1}P_{x,l})\,]
        = [\,G_v\ 0 \cdots 0,\ \ \mathrm{tria}([G_w, E])\ (\pm c_0)\,]:

    :math:`O(n)`; the old rows are untouched.

Agreement with ``joint`` mode
    On models linear in the whole state (vehicle and map) both modes are the Kalman filter
    and agree to rounding.  On nonlinear models the EKF agrees to rounding (its Jacobians
    see only the block anyway).  With the lower-triangular joint factor, joint-mode points
    along the landmark columns do not move the vehicle, so for the central-difference rule
    (step :math:`h` independent of the dimension) joint and local *prediction and
    augmentation* coincide on any model; its updates differ slightly (joint mode sees the
    block through the :math:`n`-column rows :math:`S_{r,:}`, local mode through the square
    root :math:`S_s`, and the divided differences depend on the square root).  The cubature
    and unscented rules differ in every step: joint mode applies the rule in the full
    dimension, spreading the block's points by :math:`\sqrt{n}` (cubature) instead of
    :math:`\sqrt{n_a}` with the remaining points at the block's mean - a different
    quadrature of the same nonlinearity that agrees with the local one only to the rule's
    degree (millimetres on the bailey world; see ``tests/test_local.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from scipy.linalg import lapack

from estimators.ekf import ExtendedKalmanFilter, numerical_jacobian
from estimators.linalg import (
    Array,
    NotPositiveDefiniteError,
    chol,
    chol_update_mixed,
    chol_update_sweep,
    solve_lower,
    tria,
)
from estimators.models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from estimators.rules import Factor
from estimators.sigma import SigmaPointFilter, _factorise, _gain_tri, draw
from estimators.spaces import Space

#: Filters that have a ``local`` mode.
LOCAL_FILTERS: tuple[str, ...] = ("ekf", "srckf", "srukf", "srcdkf")
#: At most this many deferred positive columns ride along before a prediction folds them.
MAX_PENDING = 12


@dataclass(frozen=True)
class Layout:
    """Where the blocks of a SLAM state are: the vehicle (``nv`` coordinates) first, then
    landmarks of ``nl`` coordinates each; ``space_of(k)`` is the space of a state with
    ``k`` landmarks (the vehicle alone is ``space_of(0)``, a block of the vehicle and
    ``k`` landmarks ``space_of(k)``)."""

    nv: int
    nl: int
    space_of: Callable[[int], Space]

    def rows(self, slots: Array) -> Array:
        """State rows of the vehicle followed by the landmarks in ``slots`` (in order)."""
        slots = np.asarray(slots, dtype=int)
        lm = self.nv + self.nl * slots[:, None] + np.arange(self.nl)[None, :]
        return np.concatenate([np.arange(self.nv), lm.ravel()])


def check_local(filt: Any) -> None:
    """Raise :class:`ValueError` unless ``filt`` has a ``local`` mode."""
    if isinstance(filt, ExtendedKalmanFilter):
        return
    if isinstance(filt, SigmaPointFilter) and filt.form == "sqrt":
        return
    raise ValueError(f"filter {getattr(filt, 'name', filt)!r} has no local mode; local mode "
                     f"supports {', '.join(LOCAL_FILTERS)}")


# --------------------------------------------------------------------------- helpers

def _unit_factor(filt: SigmaPointFilter, k: int) -> Array:
    """``U`` with ``rule.factor(S ξ).C = S U`` for a ``k``-dimensional block (``UUᵀ = I``)."""
    return _unit_factor_of(filt.rule, k)


@lru_cache(maxsize=256)
def _unit_factor_of(rule: Any, k: int) -> Array:
    xi, _ = rule.points(k)
    U = np.array(rule.factor(np.asarray(xi)).C)
    U.setflags(write=False)
    return U


def _regression(filt: SigmaPointFilter, dA: Array, dY: Array
                ) -> tuple[Array, Array, Array | None, float]:
    """Statistical linearisation of ``y`` on the block ``a``: ``(G, E, c0_y, sign)``."""
    ka = dA.shape[1]
    fac = filt.rule.factor(np.hstack([dA, dY]))
    Cy = fac.C[ka:]
    U = _unit_factor(filt, ka)
    G = Cy @ U.T
    E = Cy - G @ U
    c0 = None if fac.c0 is None else fac.c0[ka:]
    return G, E, c0, fac.sign


def _sign_fix(Q: Array, R: Array) -> tuple[Array, Array]:
    d = np.where(np.diagonal(R) < 0.0, -1.0, 1.0)
    return Q * d, R * d[:, None]


def _qr_complete(M: Array) -> tuple[Array, Array]:
    """``M = Q [R; 0]`` for a tall ``M`` (m, k): the full orthogonal ``Q`` (m, m) and the
    upper-triangular ``R`` (k, k) with a non-negative diagonal (LAPACK geqrf/orgqr)."""
    m, k = M.shape
    qr, tau, _, info = lapack.dgeqrf(np.array(M, order="F"))
    if info != 0:
        raise np.linalg.LinAlgError(f"QR failed (LAPACK info {info})")
    R = np.triu(qr[:k])
    A = np.zeros((m, m), order="F")
    A[:, :k] = qr
    Q, _, info = lapack.dorgqr(A, np.concatenate([tau, np.zeros(m - len(tau))]))
    if info != 0:
        raise np.linalg.LinAlgError(f"QR failed (LAPACK info {info})")
    d = np.where(np.diagonal(R) < 0.0, -1.0, 1.0)
    Q[:, :k] *= d
    return Q, R * d[:, None]


# --------------------------------------------------------------------------- prediction

def local_predict(filt: Any, belief: Belief, model: Transition, u: Any, layout: Layout
                  ) -> Belief:
    """Predict the vehicle with ``model`` (a transition of the vehicle alone, state space
    ``layout.space_of(0)``); the map follows by the exact linear relations."""
    nv = layout.nv
    vspace = layout.space_of(0)
    x = belief.mean
    if isinstance(filt, ExtendedKalmanFilter):
        return _ekf_predict(filt, belief, model, u, layout)
    S = belief.sqrt
    bv = SqrtGaussian(x[:nv], S[:nv, :nv], vspace)
    X, W, dX, wm = draw(filt.rule, bv, None if model.additive else model.noise,
                        filt.sqrt_method)
    Y = model.f(X, u) if model.additive else model.f(X, u, W)
    out = model.space or vspace
    ybar = out.mean(Y, wm)
    G, E, c0, sign = _regression(filt, np.hstack([dX, W]), out.local(ybar, Y))
    extra = [G[:, nv:], E]
    if model.additive:
        extra.append(model.noise.sqrt)
    if c0 is not None and sign > 0:
        extra.append(c0[:, None])
    T = tria(np.hstack(extra))
    Q, R = _qr_complete(np.hstack([G[:, :nv], T]).T)                     # [G_v, T]ᵀ = QR
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
    mean = np.concatenate([ybar, x[nv:]])
    return SqrtGaussian(mean, Sn, belief.space)


def _jacobians(model: Transition, x: Array, u: Any, space_in: Space, space_out: Space,
               eps: float) -> tuple[Array, Array | None, Array]:
    """``(F, G or None, y)`` of a transition at ``x`` (analytic if given, else numerical)."""
    if model.additive:
        if model.jacobian is not None:
            return model.jacobian(x, u), None, model.f(x[None, :], u)[0]
        F, y = numerical_jacobian(lambda X, W: model.f(X, u), x, space_in, space_out, 0, eps)
        return F, None, y
    nw = model.noise.dim
    if model.jacobian is not None:
        F, G = model.jacobian(x, u)
        return F, G, model.f(x[None, :], u, np.zeros((1, nw)))[0]
    J, y = numerical_jacobian(lambda X, W: model.f(X, u, W), x, space_in, space_out, nw, eps)
    return J[:, :space_in.dim], J[:, space_in.dim:], y


def _ekf_predict(filt: ExtendedKalmanFilter, belief: Belief, model: Transition, u: Any,
                 layout: Layout) -> Gaussian:
    nv = layout.nv
    vspace = layout.space_of(0)
    P = belief.cov
    x = belief.mean
    F, Gw, y = _jacobians(model, x[:nv], u, vspace, model.space or vspace, filt.eps)
    Q = model.noise.cov if Gw is None else Gw @ model.noise.cov @ Gw.T
    Pn = P.copy()
    Pvv = F @ P[:nv, :nv] @ F.T + Q
    Pn[:nv, :nv] = 0.5 * (Pvv + Pvv.T)
    Pn[:nv, nv:] = F @ P[:nv, nv:]
    Pn[nv:, :nv] = Pn[:nv, nv:].T
    return Gaussian(np.concatenate([y, x[nv:]]), Pn, belief.space)


# --------------------------------------------------------------------------- update

def local_update(filt: Any, belief: Belief, slots: Array, model: Measurement, z: Array,
                 layout: Layout) -> tuple[Belief, Innovation]:
    """Update with ``model``, a measurement of the block state ``[vehicle; landmarks in
    slots]`` (space ``layout.space_of(len(slots))``)."""
    rows = layout.rows(slots)
    bspace = layout.space_of(len(slots))
    if isinstance(filt, ExtendedKalmanFilter):
        return _ekf_update(filt, belief, rows, bspace, model, z)
    x, S = belief.mean, belief.sqrt
    n = belief.dim
    top = int(rows.max()) + 1
    cols = np.r_[0:top, n:S.shape[1]]                       # pending columns too
    Sr = S[rows][:, cols]
    Om, R = np.linalg.qr(Sr.T)                              # S_r = Ω S_sᵀ (thin QR)
    Om, R = _sign_fix(Om, R)
    bs = SqrtGaussian(x[rows], R.T, bspace)
    X, _, dX, wm = draw(filt.rule, bs, None, filt.sqrt_method)
    Z = model.h(X)
    zspace = model.space
    zhat = zspace.mean(Z, wm)
    ks = len(rows)
    fac = filt.rule.factor(np.hstack([dX, zspace.local(zhat, Z)]))
    Cz = fac.C[ks:]
    c0z = None if fac.c0 is None else fac.c0[ks:]
    Szz = _factorise("sqrt", Factor(Cz, c0z, fac.sign), model.noise.sqrt)
    if not np.all(np.diagonal(Szz) > 0.0):
        raise NotPositiveDefiniteError("innovation covariance is singular")
    V = Om @ (_unit_factor(filt, ks) @ Cz.T)               # P_xz = S[:, cols] V
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


def _ekf_update(filt: ExtendedKalmanFilter, belief: Belief, rows: Array, bspace: Space,
                model: Measurement, z: Array) -> tuple[Gaussian, Innovation]:
    x, P = belief.mean, belief.cov
    xs = x[rows]
    if model.jacobian is not None:
        H, zhat = model.jacobian(xs), model.h(xs[None, :])[0]
    else:
        H, zhat = numerical_jacobian(lambda X, W: model.h(X), xs, bspace, model.space, 0,
                                     filt.eps)
    nu = model.space.local(zhat, np.asarray(z, dtype=float))
    Pxz = P[:, rows] @ H.T
    Pzz = H @ Pxz[rows] + model.noise.cov
    Szz = chol(0.5 * (Pzz + Pzz.T))
    K = _gain_tri(Pxz, Szz)
    KPxz = K @ Pxz.T
    Pn = P - KPxz - KPxz.T + K @ Pzz @ K.T
    w = solve_lower(Szz, nu)
    post = Gaussian(belief.space.retract(x, K @ nu), 0.5 * (Pn + Pn.T), belief.space)
    return post, Innovation(nu, Szz, float(w @ w))


# --------------------------------------------------------------------------- augmentation

def local_augment(filt: Any, belief: Belief, model: Transition, u: Any, layout: Layout
                  ) -> Belief:
    """Append the landmarks that ``model`` (a transition from the vehicle alone to
    ``[vehicle; new landmarks]``, i.e. built for a state without landmarks) creates."""
    nv = layout.nv
    vspace = layout.space_of(0)
    x = belief.mean
    n = belief.dim
    if model.additive:
        raise ValueError("local augmentation needs the observation noise as a model input "
                         "(a non-additive transition)")
    if isinstance(filt, ExtendedKalmanFilter):
        return _ekf_augment(filt, belief, model, u, layout)
    S = belief.sqrt
    bv = SqrtGaussian(x[:nv], S[:nv, :nv], vspace)
    X, W, dX, wm = draw(filt.rule, bv, model.noise, filt.sqrt_method)
    Yall = model.f(X, u, W)
    k = (Yall.shape[1] - nv) // layout.nl
    new_space = layout.space_of(k)
    # the new landmarks' own coordinates: local charts of the block output, minus vehicle
    ybar_all = new_space.mean(Yall, wm)
    dY = new_space.local(ybar_all, Yall)[:, nv:]
    ybar = ybar_all[nv:]
    G, E, c0, sign = _regression(filt, np.hstack([dX, W]), dY)
    extra = [G[:, nv:], E]
    if c0 is not None and sign > 0:
        extra.append(c0[:, None])
    Lll = tria(np.hstack(extra))
    if c0 is not None and sign < 0:
        Lll = chol_update_sweep(Lll, c0, -1.0)
    m = len(ybar)
    p = S.shape[1] - n                                      # pending columns stay last
    Sn = np.zeros((n + m, n + m + p))
    Sn[:n, :n] = S[:, :n]
    Sn[:n, n + m:] = S[:, n:]
    Sn[n:, :nv] = G[:, :nv]
    Sn[n:, n:n + m] = Lll
    n_lm = (n - nv) // layout.nl
    return SqrtGaussian(np.concatenate([x, ybar]), Sn, layout.space_of(n_lm + k))


def _ekf_augment(filt: ExtendedKalmanFilter, belief: Belief, model: Transition, u: Any,
                 layout: Layout) -> Gaussian:
    nv = layout.nv
    vspace = layout.space_of(0)
    x, P = belief.mean, belief.cov
    n = belief.dim
    out = model.space or vspace
    F, Gw, y = _jacobians(model, x[:nv], u, vspace, out, filt.eps)
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
    k = m // layout.nl
    n_lm = (n - nv) // layout.nl
    return Gaussian(np.concatenate([x, y[nv:]]), Pn, layout.space_of(n_lm + k))
