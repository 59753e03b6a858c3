r"""The additive-quaternion-error (AQE) alignment model of [Wu-Wang 2014] §2.

State (13, Euclidean)
---------------------
:math:`x = [\delta Q\ (4),\ \delta V^n\ (3),\ \varepsilon\ (3),\ \nabla\ (3)]`:

* :math:`\delta Q = \hat Q - Q` - the additive quaternion error of the SINS attitude
  (eq. 2; four free components, no unit-norm constraint, so no small-angle assumption);
* :math:`\delta V = \hat V - V` (East, North, Up; eq. 3);
* :math:`\varepsilon` - the gyro drift, body frame: the paper's constant drift plus its
  first-order Markov drift, one state per axis (over a 200 s alignment a random constant
  and a Markov process with τ = 3600 s cannot be told apart: the Markov part moves by
  :math:`\sigma\sqrt{2t/\tau} \approx 0.33\sigma` in 200 s); modelled as a random walk
  with the Markov's driving density :math:`2\sigma_m^2/\tau` (its decay,
  :math:`e^{-200/3600} = 0.95`, is dropped);
* :math:`\nabla` - the accelerometer bias, body frame, likewise (τ = 1800 s).

The paper's printed state vector is garbled (it lists :math:`\delta Q`, :math:`\delta V`
and drift symbols without saying which); this is the smallest list with every error
source the simulation has.  Position is not in the state: the launcher is fixed and the
measurement is velocity only.

Process model over one filter interval (exact discretisation of eq. 2-3)
------------------------------------------------------------------------
With the SINS's own attitudes :math:`\hat Q_j, \hat Q_{j+1}` and the interval increments
(:class:`slam.kinds.alignment.simulate.Increments`; :math:`E = \mathrm{Exp}(-\omega_{ie}^n T)`):

.. math::

    Q_j &= \hat Q_j - \delta Q_j, \qquad
    Q_{j+1} = E \otimes Q_j \otimes \Delta R \otimes \mathrm{Exp}(-A\varepsilon),\qquad
    \delta Q_{j+1} = \hat Q_{j+1} - Q_{j+1},

    \delta V_{j+1} &= \delta V_j - 2\,\omega_{ie}^n \times \delta V_j\,T
        + (\hat C - C)\,\Delta v - [\omega_{ie}^n]_\times (\hat C - C)\,\Delta v_1
        + C\,(B_\nabla \nabla - B_\varepsilon \varepsilon),

with :math:`C = C(Q_j) = R(Q_j/\lVert Q_j\rVert)` the rotation matrix of the (unnormalised)
filter quaternion :math:`Q_j = \hat Q_j - \delta Q_j` (eq. 3: the quaternion error enters the
velocity error through :math:`C(\hat Q - \delta Q)`, nonlinearly) and
:math:`\hat C = C(\hat Q_j)`.  :math:`\delta Q` is linear in its own dynamics (quaternion
products are bilinear); the drift enters through :math:`\mathrm{Exp}` (first order in
:math:`A\varepsilon` would be the paper's :math:`Y(\hat Q)\varepsilon`).
The gravity terms cancel; the Earth-rate factor inside the interval is kept to first
order (:math:`(\omega_{ie}T)^2 \approx 5\cdot10^{-11}`).

Additive process noise per interval (white gyro σ_g and accelerometer σ_a per sample,
``dt`` the IMU interval): :math:`\delta Q`: :math:`\tfrac14\sigma_g^2\,dt\,T\,I_4` (the
tangent angle noise :math:`\sigma_g^2 dt T` spread over the four components - the
component along :math:`Q` is an over-bound); :math:`\delta V`: :math:`\sigma_a^2 dt T I_3`;
drifts: :math:`2\sigma_m^2 T/\tau` per axis.

Why :math:`R(Q/\lVert Q\rVert)` and not the paper's quadratic form
:math:`\lVert Q\rVert^2 R(Q/\lVert Q\rVert)` (``normalised=False`` keeps it, for the tests):
the true :math:`Q` has unit norm, so on the truth both are equal, but the quadratic form turns
the vertical channel into a sensor of the filter's own redundant coordinate - a state with
:math:`\lVert Q\rVert^2 = 1 + \epsilon` predicts a vertical velocity error of
:math:`\epsilon g T` per interval, about :math:`10^2\epsilon` σ_v.  The four free components of
:math:`\delta Q` then get a very precise "measurement" of the unit-norm constraint, linearised
at an estimate that keeps moving along the curved set of unit quaternions: the Gaussian is
squeezed along the constraint's normal at each new point, which for a 30° azimuth spread has
a component along the azimuth, and the filters shrank the azimuth σ from 30° to about 1° with
the error still near 30° (measured: calm launcher, 30° prior, UKF/EKF; with the vertical
velocity left out the collapse stops).  With the normalised form the velocity error is
invariant to the scale of :math:`Q`; the gravity direction fixes the tilt, and the attitudes
with one tilt form a linear subspace :math:`\mathrm{span}\{Q, \hat z \otimes Q\}` of the
:math:`\delta Q` space, so the azimuth's unobservable direction is the same at every
linearisation point.

What is left (measured, see the report): the zero-velocity reference treats the launcher's
wind motion :math:`v` as white noise, but the accelerometers sense that motion, and a rotation
about the vertical of a sensed motion leaves the likelihood of the velocities exactly flat in
azimuth while its linearisation :math:`R(\psi)v \approx v + \psi\,\hat z \times v` gains
:math:`\lVert v_h\rVert^2/\sigma_v^2` (1.7 rad⁻²) per update: the filters' azimuth σ
still shrinks, to about 1.5° over 200 s under the wind (not in a calm), while the error
stays near its initial value (``tests/slam/kinds/alignment/test_consistency.py``).

Measurement: the SINS velocity against the launcher's zero-velocity reference,
:math:`z = \hat V = \delta V + v`, with :math:`v \sim N(0, \sigma_v^2 I_3)` standing for the
sway/wind motion the reference ignores (eq. 4, :math:`H = [0\ I_3\ 0]`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial.hermite_e import hermegauss
from numpy.typing import NDArray

from estimators import Measurement, Noise, Transition
from nav.quaternion import qexp, qlog, qmul, qnormalize, qto_dcm, skew
from nav.strapdown import hamilton
from slam.kinds.alignment.simulate import AlignmentLog
from slam.kinds.alignment.world import AlignmentWorld

Array = NDArray[np.float64]

__all__ = ["N_STATE", "aqe_transition", "initial_belief", "misalignment_error",
           "quadratic_dcm", "true_state", "velocity_measurement"]

N_STATE = 13
Q_, V_, G_, A_ = slice(0, 4), slice(4, 7), slice(7, 10), slice(10, 13)


def quadratic_dcm(Q: Array) -> Array:
    r""":math:`C(Q) = \lVert Q\rVert^2 R(Q/\lVert Q\rVert)` (..., 3, 3): the rotation
    matrix formula of eq. 3 applied to an unnormalised quaternion."""
    Q = np.asarray(Q, dtype=np.float64)
    n2 = np.sum(Q * Q, axis=-1)
    return qto_dcm(Q) * n2[..., None, None]


def quadratic_rotate(Q: Array, v: Array) -> Array:
    r""":math:`C(Q)\,v = Q \otimes v \otimes Q^*` for unnormalised ``Q`` (m, 4), ``v``
    (m, 3), (3,) or (m, k, 3) (k vectors per quaternion):
    :math:`(w^2 - u^\top u)v + 2(u^\top v)u + 2w\,u \times v`."""
    batch = np.ndim(v) == 3
    w, u = (Q[:, None, :1], Q[:, None, 1:]) if batch else (Q[:, :1], Q[:, 1:])
    v = np.broadcast_to(v, np.broadcast_shapes(u.shape, np.shape(v)))
    uxv = np.empty(v.shape)
    uxv[..., 0] = u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1]
    uxv[..., 1] = u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2]
    uxv[..., 2] = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return ((w * w - np.sum(u * u, axis=-1, keepdims=True)) * v
            + 2.0 * np.sum(u * v, axis=-1, keepdims=True) * u + 2.0 * w * uxv)


class _AqeMap:
    r"""The AQE interval map (module docstring) with its per-epoch constants:
    :math:`a_j = \hat C_j\Delta v_j - [\omega]_\times \hat C_j \Delta v_{1,j}`."""

    def __init__(self, log: AlignmentLog, normalised: bool = True) -> None:
        self.log, inc, T = log, log.inc, log.T
        self.normalised = normalised
        self.turn = qexp(-log.earth_rate * T)
        self.Wt = skew(log.earth_rate).T
        self.F = np.eye(3) - 2.0 * T * skew(log.earth_rate)
        C = qto_dcm(log.sins_q[:-1])
        self.a = ((C @ inc.dv[..., None])[..., 0]
                  - (C @ inc.dv1[..., None])[..., 0] @ self.Wt)
        # E ⊗ Q0 ⊗ ΔR = L(E) R(ΔR) Q0 (left and right products commute): one (4, 4) per epoch
        self.L_turn = _left(self.turn)
        self.K = self.L_turn @ _right_matrix(inc.dq)

    def __call__(self, X: Array, j: int) -> Array:
        X = np.atleast_2d(X)
        log, inc = self.log, self.log.inc
        dq, dV, eps, nab = X[:, Q_], X[:, V_], X[:, G_], X[:, A_]
        Q0 = log.sins_q[j] - dq
        Q1 = hamilton(Q0 @ self.K[j].T, qexp(-(eps @ inc.A[j].T)))
        corr = nab @ inc.B_acc[j].T - eps @ inc.B_gyro[j].T
        both = np.empty((X.shape[0], 2, 3))
        both[:, 0] = corr - inc.dv[j]
        both[:, 1] = inc.dv1[j]
        Cv = quadratic_rotate(Q0, both)
        rot = Cv[:, 0] + Cv[:, 1] @ self.Wt
        if self.normalised:
            rot = rot / np.sum(Q0 * Q0, axis=1, keepdims=True)
        dV1 = dV @ self.F.T + self.a[j] + rot
        return np.hstack([log.sins_q[j + 1] - Q1, dV1, eps, nab])

    def jacobian(self, x: Array, j: int) -> Array:
        r""":math:`\partial f/\partial x` (13, 13) at ``x`` for the EKF: :math:`\delta Q`
        enters linearly (:math:`L(E)\,R(\Delta R\,\mathrm{Exp}(-A\varepsilon))`), the drift
        through :math:`\partial\mathrm{Exp}(\phi)/\partial\phi \approx [-\phi^\top/4;\
        \tfrac12 I]` (:math:`|\phi| = |A\varepsilon| \sim 10^{-5}`), and the velocity
        error through :func:`quadratic_rotate_jacobian`."""
        log, inc = self.log, self.log.inc
        dq, eps = x[Q_], x[G_]
        Q0 = log.sins_q[j] - dq
        phi = -(inc.A[j] @ eps)
        tail = hamilton(inc.dq[j], qexp(phi))
        F = np.zeros((N_STATE, N_STATE))
        F[Q_, Q_] = self.L_turn @ _right_matrix(tail)
        dexp = np.vstack([-phi / 4.0, 0.5 * np.eye(3)])
        F[Q_, G_] = _left(self.K[j] @ Q0) @ dexp @ inc.A[j]
        n2 = float(Q0 @ Q0)
        C = qto_dcm(Q0) if self.normalised else n2 * qto_dcm(Q0)
        corr = inc.B_acc[j] @ x[A_] - inc.B_gyro[j] @ eps
        W = self.Wt.T
        u, u1 = corr - inc.dv[j], inc.dv1[j]
        J = quadratic_rotate_jacobian(Q0, u) + W @ quadratic_rotate_jacobian(Q0, u1)
        if self.normalised:   # C(Q)v / |Q|^2 with C(Q)v = |Q|^2 R(Q/|Q|) v
            rot = C @ u + W @ (C @ u1)
            J = J / n2 - np.outer(rot, 2.0 * Q0) / n2
        F[V_, Q_] = -J
        F[V_, V_] = self.F
        F[V_, G_] = -C @ inc.B_gyro[j]
        F[V_, A_] = C @ inc.B_acc[j]
        F[G_, G_] = F[A_, A_] = np.eye(3)
        return F


def _left(p: Array) -> Array:
    """(4, 4) ``L`` with ``p ⊗ q = L q``."""
    return hamilton(p, np.eye(4)).T


def quadratic_rotate_jacobian(Q: Array, v: Array) -> Array:
    r""":math:`\partial (C(Q)v)/\partial Q` (3, 4) of :func:`quadratic_rotate`:
    :math:`[2wv + 2u\times v,\ 2(u^\top v)I + 2uv^\top - 2vu^\top - 2w[v]_\times]`."""
    w, u = Q[0], Q[1:]
    return np.hstack([(2.0 * w * v + 2.0 * np.cross(u, v))[:, None],
                      2.0 * (u @ v) * np.eye(3) + 2.0 * np.outer(u, v) - 2.0 * np.outer(v, u)
                      - 2.0 * w * skew(v)])


def _propagate(X: Array, j: int, log: AlignmentLog) -> Array:
    """The AQE interval map for points ``X`` (m, 13), interval ``j`` (tests; the filters
    use one :class:`_AqeMap` per run)."""
    return _AqeMap(log)(X, j)


def process_noise(world: AlignmentWorld, T: float) -> Noise:
    """The additive noise of one interval (module docstring)."""
    m, dt = world.imu, world.imu.dt_s
    var = np.concatenate([
        np.full(4, 0.25 * m.gyro_white_rad_s**2 * dt * T),
        np.full(3, m.accel_white_mps2**2 * dt * T),
        np.full(3, 2.0 * m.gyro_markov_rad_s**2 * T / m.gyro_markov_tau_s),
        np.full(3, 2.0 * m.accel_markov_mps2**2 * T / m.accel_markov_tau_s)])
    return Noise.from_cov(np.diag(np.maximum(var, 1e-30)))


def aqe_transition(world: AlignmentWorld, log: AlignmentLog, normalised: bool = True
                   ) -> Transition:
    """One filter interval of the AQE model; the input ``u`` is the interval index.
    ``normalised=False``: the paper's quadratic :math:`C(Q)` (see the module docstring)."""
    f = _AqeMap(log, normalised)
    return Transition(lambda X, j: f(X, int(j)), process_noise(world, log.T),
                      jacobian=lambda x, j: f.jacobian(np.asarray(x, dtype=np.float64), int(j)))


def velocity_measurement(sigma: float) -> Measurement:
    """:math:`z = \\delta V + v`, :math:`v \\sim N(0, \\sigma^2 I_3)`."""
    H = np.zeros((3, N_STATE))
    H[:, V_] = np.eye(3)
    return Measurement(lambda X: np.atleast_2d(X)[:, V_], Noise.from_cov(sigma**2 * np.eye(3)),
                       jacobian=lambda x: H)


def _delta_q_moments(q_hat: Array, sigma: Array, order: int = 7) -> tuple[Array, Array]:
    r"""Mean and covariance of :math:`\delta Q = \hat Q - \mathrm{Exp}(\phi)\otimes\hat Q`,
    :math:`\phi \sim N(0, \mathrm{diag}\,\sigma^2)` (nav frame), by a Gauss-Hermite product
    rule of ``order`` points per axis (exact for polynomials of degree < 2·order)."""
    x, w = hermegauss(order)
    w = w / w.sum()
    grid = np.stack(np.meshgrid(x, x, x, indexing="ij"), axis=-1).reshape(-1, 3)
    wt = np.prod(np.stack(np.meshgrid(w, w, w, indexing="ij"), axis=-1).reshape(-1, 3), axis=1)
    dq = q_hat - qmul(qexp(grid * sigma), q_hat)
    mean = wt @ dq
    dev = dq - mean
    return mean, (dev * wt[:, None]).T @ dev


def initial_belief(world: AlignmentWorld, log: AlignmentLog) -> tuple[Array, Array]:
    """``(x0, P0)``: the SINS does not know its misalignment, so :math:`\\delta Q` starts at
    its prior mean with the prior's covariance (:func:`_delta_q_moments`); zero velocity
    error (σ_v), zero drift and bias with the world's total σ (constant and Markov)."""
    f, m = world.filters, world.imu
    mean, cov = _delta_q_moments(log.sins_q[0], np.asarray(f.initial_sigma_rad))
    x0 = np.concatenate([mean, np.zeros(9)])
    sg = math.hypot(m.gyro_bias_rad_s, m.gyro_markov_rad_s)
    sa = math.hypot(m.accel_bias_mps2, m.accel_markov_mps2)
    P0 = np.zeros((N_STATE, N_STATE))
    P0[Q_, Q_] = cov + 1e-14 * np.eye(4)
    P0[V_, V_] = f.velocity_sigma_mps**2 * np.eye(3)
    P0[G_, G_] = max(sg, 1e-12) ** 2 * np.eye(3)
    P0[A_, A_] = max(sa, 1e-12) ** 2 * np.eye(3)
    return x0, P0


def _right_matrix(p: Array) -> Array:
    """(..., 4, 4) ``R`` with ``d ⊗ p = R d`` (``p`` (..., 4))."""
    return np.swapaxes(qmul(np.eye(4), p[..., None, :]), -1, -2)


def misalignment_error(sins_q: Array, dq: Array, P_dq: Array, q_true: Array
                       ) -> tuple[Array, Array]:
    r"""``(err, cov)``: the residual misalignment :math:`\mathrm{Log}(q_{est} \otimes
    q^*)` (M, 3; East, North, Up) of the corrected attitude
    :math:`q_{est} = (\hat Q - \delta\hat Q)/\lVert\cdot\rVert`, and its (M, 3, 3)
    covariance from the filter's :math:`P_{\delta Q}` through
    :math:`J = -\tfrac{2}{\lVert Q\rVert}\,[R(q_{est}^*)]_{1:4}`."""
    Q = sins_q - dq
    q_est = qnormalize(Q)
    err = qlog(qmul(q_est, q_true * np.array([1.0, -1.0, -1.0, -1.0])))
    conj = q_est * np.array([1.0, -1.0, -1.0, -1.0])
    J = -2.0 / np.linalg.norm(Q, axis=-1)[:, None, None] * _right_matrix(conj)[:, 1:, :]
    return err, J @ P_dq @ np.swapaxes(J, -1, -2)


def true_state(log: AlignmentLog) -> Array:
    """(M, 13) the true error state (the sign of :math:`Q` taken nearest :math:`\\hat Q`)."""
    q = log.truth_q * np.sign(np.sum(log.truth_q * log.sins_q, axis=1))[:, None]
    return np.hstack([log.sins_q - q, log.sins_v - log.truth_v, log.gyro_drift,
                      log.accel_bias])
