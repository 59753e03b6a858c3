r"""Quaternion SINS/SLAM models: strapdown prediction, range/azimuth/elevation updates,
inverse-observation augmentation ([Wang SRCKF-SLAM] §4).

State and space
---------------
Ambient (16 + 3N): ``[p (3), v (3), q (4), b_g (3), b_a (3), m_1 (3), ..., m_N (3)]`` with
ENU position/velocity, attitude ``q_nb`` (body forward-left-up), gyro and accelerometer
biases and the landmark positions.  Tangent (15 + 3N): ``[δp, δv, δθ, δb_g, δb_a, δm]`` on
``Product([Euclidean(6), UnitQuaternion(), Euclidean(6 + 3N)])``, the attitude error a
body-frame rotation vector, :math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)` (GTSAM's
``Rot3.retract``).  Sigma points are drawn on the 3-vector attitude error and mapped onto
the quaternion by multiplication; means of quaternions are Karcher means in the same
chart, so the estimate is unit-norm by construction (paper §4.1-4.2, done as in
Arasaratnam & Haykin's square-root cubature filter).

Prediction: one :class:`~estimators.Transition` per sensor epoch
---------------------------------------------------------------------
``f(X, u)`` mechanises every sigma point through the ``n`` IMU samples ``u = (gyro,
accel)`` of the epoch with its own bias estimates, :math:`\tilde\omega_k - b_g` and
:math:`\tilde f_k - b_a` (:func:`nav.strapdown.mechanise`, all points and samples
vectorised); biases and landmarks are carried unchanged.  The IMU white noise and the
bias random walks enter as **additive noise in the error-state tangent** at the end of
the epoch, :math:`Q = \sum_k \Phi_{n \leftarrow k+1}\,Q_k\,\Phi_{n \leftarrow k+1}^\top`,
accumulated along the mean's mechanisation with the continuous error dynamics

.. math::

    \dot{\delta p} = \delta v,\quad
    \dot{\delta v} = -C[f\times]\,\delta\theta - C\,\delta b_a - 2[\omega_{ie}\times]\delta v
                     - C\,n_a,\quad
    \dot{\delta\theta} = -[\omega\times]\,\delta\theta - \delta b_g - n_g,\quad
    \dot{\delta b_g} = n_{bg},\quad \dot{\delta b_a} = n_{ba},

densities :math:`\sigma_a^2, \sigma_g^2, \sigma_{bg}^2, \sigma_{ba}^2` (isotropic, so
:math:`C` drops out of :math:`GQ_cG^\top = \mathrm{diag}(0, \sigma_a^2 I, \sigma_g^2 I,
\sigma_{bg}^2 I, \sigma_{ba}^2 I)`), discretised per IMU sample to second order,

.. math::

    \Phi_k = I + F_k\Delta t + \tfrac12 F_k^2\Delta t^2,\qquad
    Q_k = Q_c\Delta t + \tfrac12(F_kQ_c + Q_cF_k^\top)\Delta t^2
          + \tfrac13 F_kQ_cF_k^\top\Delta t^3 .

The product :math:`\Phi = \Phi_{n-1}\cdots\Phi_0` is the EKF's transition Jacobian
(landmarks: identity).  The bias is held constant over the epoch in every point (its
random walk over the epoch is in :math:`Q`).

Measurement
-----------
Landmark ``m`` seen from ``(p, q)``: :math:`d = C(q)^\top (m - p)` in the body frame,

.. math::

    z = \big[\lVert d\rVert,\ \operatorname{atan2}(d_y, d_x),\
        \operatorname{atan2}(d_z, \lVert(d_x, d_y)\rVert)\big]
      = [r,\ \text{azimuth},\ \text{elevation}],

stacked for the landmarks of one epoch on ``Wrapped(3k, azimuth indices)``.
Augmentation inverts it, :math:`m = p + C(q)\,r\,[\cos e\cos a, \cos e\sin a, \sin e]`,
as a dimension-changing transition with the observation noise as a non-additive input,
so sigma-point filters get the new landmark's cross-covariances with the whole state
from the same points.  Analytic Jacobians are given for the EKF.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Self

import numpy as np

from estimators import Euclidean, Measurement, Noise, Product, Transition, Wrapped
from estimators.linalg import Array
from nav.ins import compose as _compose
from nav.ins import psd_sqrt as psd_sqrt
from nav.quaternion import qconj, qrotate, qto_dcm, skew
from nav.spaces import UnitQuaternion
from nav.strapdown import attitudes, dcm_unit, mechanise

QUAT = UnitQuaternion()
#: Ambient slices of the vehicle part.
P, V, Q, BG, BA = slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(13, 16)
#: Tangent slices of the vehicle part.
TP, TV, TTH, TBG, TBA = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)
VEH_AMBIENT = 16
VEH_DIM = 15
POSE_ROWS = np.r_[0:3, 6:9]  # tangent rows of [δp, δθ]


def state_space(n_landmarks: int) -> Product:
    """The joint state's space with ``n_landmarks`` landmarks."""
    return Product([Euclidean(6), QUAT, Euclidean(6 + 3 * n_landmarks)])


def landmark_rows(slot: int) -> Array:
    """Tangent rows of landmark ``slot``."""
    return np.arange(VEH_DIM + 3 * slot, VEH_DIM + 3 * slot + 3)


@dataclass(frozen=True)
class ImuNoise:
    """Continuous-time densities the filter assumes (per √s): gyro white noise
    (rad/√s), accelerometer white noise (m/s/√s), gyro bias random walk (rad/s/√s),
    accelerometer bias random walk (m/s²/√s)."""

    gyro_arw: float
    accel_vrw: float
    gyro_bias_rw: float
    accel_bias_rw: float

    def qc(self) -> Array:
        """Diagonal of :math:`GQ_cG^\\top` on the 15-d vehicle error state."""
        return np.concatenate([np.zeros(3), np.full(3, self.accel_vrw**2),
                               np.full(3, self.gyro_arw**2), np.full(3, self.gyro_bias_rw**2),
                               np.full(3, self.accel_bias_rw**2)])

    def scaled(self, variance_scale: float) -> Self:
        """These densities for variances ``variance_scale`` times larger (same type)."""
        s = float(np.sqrt(variance_scale))
        return replace(self, gyro_arw=self.gyro_arw * s, accel_vrw=self.accel_vrw * s,
                       gyro_bias_rw=self.gyro_bias_rw * s, accel_bias_rw=self.accel_bias_rw * s)


@dataclass(frozen=True)
class NavFrame:
    """IMU period ``dt`` (s), gravity :math:`g^n` (3,) and Earth rate (3,) or ``None``."""

    dt: float
    gravity: Array
    earth_rate: Array | None = None


# --------------------------------------------------------------------------- prediction

def propagate_points(X: Array, gyro: Array, accel: Array, nav: NavFrame) -> Array:
    """Mechanise states ``X`` (m, 16 + 3N) through one epoch's IMU samples (n, 3) each (a
    batch of runs: ``X`` (..., m, ·) with ``gyro``, ``accel`` (..., n, 3); the points of
    every run are mechanised together)."""
    if X.ndim > 2:
        lead, m = X.shape[:-2], X.shape[-2]
        flat = X.reshape(-1, X.shape[-1])
        w = (gyro[..., None, :, :] - X[..., BG][..., None, :]).reshape(flat.shape[0], -1, 3)
        f = (accel[..., None, :, :] - X[..., BA][..., None, :]).reshape(flat.shape[0], -1, 3)
        p, v, q = mechanise(flat[:, P], flat[:, V], flat[:, Q], w, f, nav.dt, nav.gravity,
                            nav.earth_rate)
        Y = flat.copy()
        Y[:, P], Y[:, V], Y[:, Q] = p, v, q
        return Y.reshape(lead + (m, X.shape[-1]))
    bg, ba = X[:, BG], X[:, BA]
    p, v, q = mechanise(X[:, P], X[:, V], X[:, Q], gyro[None] - bg[:, None],
                        accel[None] - ba[:, None], nav.dt, nav.gravity, nav.earth_rate)
    Y = X.copy()
    Y[:, P], Y[:, V], Y[:, Q] = p, v, q
    return Y


def error_transitions(C: Array, w: Array, f: Array, nav: NavFrame, noise: ImuNoise
                      ) -> tuple[Array, Array]:
    """Epoch ``(Φ, Q)`` from the mean's per-sample attitude matrices ``C`` (..., n, 3, 3),
    bias-corrected rates ``w`` and specific forces ``f`` (..., n, 3): returns
    (..., 15, 15) arrays, composed over the sample axis (module docstring)."""
    dt = nav.dt
    F = np.zeros(w.shape[:-1] + (VEH_DIM, VEH_DIM))
    idx = np.arange(3)
    F[..., idx, 3 + idx] = 1.0  # δp' = δv
    F[..., TV, TTH] = -C @ skew(f)
    F[..., TV, TBA] = -C
    F[..., TTH, TTH] = -skew(w)
    F[..., 6 + idx, 9 + idx] = -1.0  # δθ' = -δb_g
    if nav.earth_rate is not None and np.any(nav.earth_rate):
        F[..., TV, TV] = -2.0 * skew(np.asarray(nav.earth_rate, dtype=float))
    Fdt = F * dt
    Phis = Fdt + 0.5 * Fdt @ Fdt
    Phis[..., np.arange(VEH_DIM), np.arange(VEH_DIM)] += 1.0
    qc = noise.qc()
    FQ = F * qc  # F Qc
    FQt = np.swapaxes(FQ, -1, -2)
    Qks = 0.5 * (FQ + FQt) * dt**2 + (FQ @ np.swapaxes(F, -1, -2)) * (dt**3 / 3.0)
    Qks[..., np.arange(VEH_DIM), np.arange(VEH_DIM)] += qc * dt
    Phi, Qacc = _compose(Phis, Qks)
    return Phi, 0.5 * (Qacc + np.swapaxes(Qacc, -1, -2))


def error_transition(x: Array, gyro: Array, accel: Array, nav: NavFrame, noise: ImuNoise
                     ) -> tuple[Array, Array]:
    """``(Φ, Q)`` of the 15-d vehicle error state over one epoch, along the mean ``x`` (a
    batch: ``x`` (..., n) with ``gyro``, ``accel`` (..., n_s, 3))."""
    w = gyro - x[..., BG][..., None, :]
    f = accel - x[..., BA][..., None, :]
    qs = attitudes(x[..., Q], w, nav.dt, nav.earth_rate)
    return error_transitions(dcm_unit(qs[..., :-1, :]), w, f, nav, noise)


def imu_transition(x_mean: Array, n_landmarks: int, gyro: Array, accel: Array, nav: NavFrame,
                   noise: ImuNoise) -> Transition:
    """The epoch's prediction: ``f(X, (gyro, accel))`` with additive tangent noise ``Q``
    (zero on the landmarks) computed along the mean ``x_mean``; EKF Jacobian
    ``blkdiag(Φ, I)``."""
    Phi, Qv = error_transition(x_mean, gyro, accel, nav, noise)
    d = VEH_DIM + 3 * n_landmarks
    lead = np.shape(x_mean)[:-1]  # a batch of means: one model per run
    cov = np.zeros(lead + (d, d))
    cov[..., :VEH_DIM, :VEH_DIM] = Qv
    sqrt = np.zeros(lead + (d, d))
    sqrt[..., :VEH_DIM, :VEH_DIM] = psd_sqrt(Qv)
    F = np.broadcast_to(np.eye(d), lead + (d, d)).copy()
    F[..., :VEH_DIM, :VEH_DIM] = Phi

    def f(X: Array, u: tuple[Array, Array]) -> Array:
        return propagate_points(X, u[0], u[1], nav)

    return Transition(f, Noise(cov, sqrt), additive=True, jacobian=lambda x, u: F)


# --------------------------------------------------------------------------- measurement

def observation_space(k: int) -> Wrapped:
    """Space of ``k`` stacked ``[range, azimuth, elevation]`` (azimuths wrapped)."""
    return Wrapped(3 * k, tuple(range(1, 3 * k, 3)))


def body_vectors(X: Array, slots: Array) -> Array:
    """Landmarks at ``slots`` in the body frame of every point: (m, k, 3)."""
    cols = VEH_AMBIENT + 3 * np.asarray(slots, dtype=int)[:, None] + np.arange(3)
    m = X[..., cols]  # (..., m, k, 3)
    return qrotate(qconj(X[..., None, Q]), m - X[..., None, P])


def rae_of(d: Array) -> Array:
    """``[r, azimuth, elevation]`` of body vectors ``d`` (..., 3)."""
    rho = np.hypot(d[..., 0], d[..., 1])
    return np.stack([np.sqrt(rho * rho + d[..., 2] ** 2), np.arctan2(d[..., 1], d[..., 0]),
                     np.arctan2(d[..., 2], rho)], axis=-1)


def rae(X: Array, slots: Array) -> Array:
    """Stacked ``[r, az, el]`` of the landmarks at ``slots``: (m, 3k) (leading axes: a
    batch)."""
    return rae_of(body_vectors(X, slots)).reshape(X.shape[:-1] + (-1,))


def rae_jacobian_d(d: Array) -> Array:
    """∂[r, az, el]/∂d at body vectors ``d`` (..., k, 3): (..., k, 3, 3)."""
    dx, dy, dz = d[..., 0], d[..., 1], d[..., 2]
    rho2 = dx * dx + dy * dy
    rho = np.sqrt(rho2)
    r2 = rho2 + dz * dz
    r = np.sqrt(r2)
    J = np.zeros(d.shape[:-1] + (3, 3))
    J[..., 0, :] = d / r[..., None]
    J[..., 1, 0], J[..., 1, 1] = -dy / rho2, dx / rho2
    J[..., 2, 0], J[..., 2, 1], J[..., 2, 2] = (-dx * dz / (r2 * rho), -dy * dz / (r2 * rho),
                                                rho / r2)
    return J


def rae_jacobian(x: Array, slots: Array) -> Array:
    """Analytic Jacobian (3k, d) of :func:`rae` at one state ``x`` in tangent coordinates
    (a batch ``x`` (..., n) gives (..., 3k, d))."""
    slots = np.asarray(slots, dtype=int)
    if x.ndim > 1:
        return _rae_jacobian_batch(x, slots)
    n_lm = (x.shape[0] - VEH_AMBIENT) // 3
    d_all = body_vectors(x[None], slots)[0]  # (k, 3)
    Jd = rae_jacobian_d(d_all)
    Ct = qto_dcm(x[Q]).T
    H = np.zeros((3 * len(slots), VEH_DIM + 3 * n_lm))
    for i, s in enumerate(slots):
        rows = slice(3 * i, 3 * i + 3)
        H[rows, TP] = -Jd[i] @ Ct
        H[rows, TTH] = Jd[i] @ skew(d_all[i])
        H[rows, VEH_DIM + 3 * s:VEH_DIM + 3 * s + 3] = Jd[i] @ Ct
    return H


def _rae_jacobian_batch(x: Array, slots: Array) -> Array:
    lead, k = x.shape[:-1], len(slots)
    n_lm = (x.shape[-1] - VEH_AMBIENT) // 3
    d_all = body_vectors(x[..., None, :], slots)[..., 0, :, :]  # (..., k, 3)
    Jd = rae_jacobian_d(d_all)  # (..., k, 3, 3)
    Ct = np.swapaxes(qto_dcm(x[..., Q]), -1, -2)[..., None, :, :]  # (..., 1, 3, 3)
    H = np.zeros(lead + (k, 3, VEH_DIM + 3 * n_lm))
    JC = Jd @ Ct
    H[..., TP] = -JC
    H[..., TTH] = Jd @ skew(d_all)
    for i, s in enumerate(slots):
        H[..., i, :, VEH_DIM + 3 * s:VEH_DIM + 3 * s + 3] = JC[..., i, :, :]
    return H.reshape(lead + (3 * k, VEH_DIM + 3 * n_lm))


def observation_model(slots: Array, obs_cov: Array) -> Measurement:
    """Batch measurement of the landmarks in ``slots`` (one ``[r, az, el]`` each)."""
    slots = np.asarray(slots, dtype=int)
    k = len(slots)
    cov = np.kron(np.eye(k), obs_cov)
    return Measurement(lambda X: rae(X, slots), Noise(cov, np.kron(np.eye(k), psd_sqrt(obs_cov))),
                       space=observation_space(k), jacobian=lambda x: rae_jacobian(x, slots))


# --------------------------------------------------------------------------- augmentation

def direction(Z: Array) -> Array:
    """Unit body vectors of ``[r, az, el]`` rows (..., 3) (range ignored)."""
    a, e = Z[..., 1], Z[..., 2]
    ce = np.cos(e)
    return np.stack([ce * np.cos(a), ce * np.sin(a), np.sin(e)], axis=-1)


def landmarks_from_rae(X: Array, Z: Array) -> Array:
    """Inverse observation: (m, 3k) landmark positions from states ``X`` and ``Z`` (m, 3k)
    (leading axes: a batch)."""
    lead = np.broadcast_shapes(X.shape[:-1], Z.shape[:-1])
    Zr = Z.reshape(Z.shape[:-1] + (-1, 3))
    d = Zr[..., :1] * direction(Zr)  # (..., m, k, 3)
    return (X[..., None, P] + qrotate(X[..., None, Q], d)).reshape(lead + (-1,))


def augmentation_model(n_landmarks: int, z_new: Array, obs_cov: Array) -> Transition:
    """Grow the state by the landmarks first seen in ``z_new`` (3k,): ``s' = [s; g(s, z + v)]``.

    Non-additive: sigma-point filters draw points over ``[s; v]`` with ``v`` the
    observation noise; the EKF uses the analytic Jacobians.
    """
    k = z_new.shape[0] // 3
    n = VEH_DIM + 3 * n_landmarks

    def f(X: Array, u: Array, W: Array) -> Array:
        return np.concatenate([X, landmarks_from_rae(X, u[..., None, :] + W)], axis=-1)

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        if x.ndim > 1:
            return _augmentation_jacobian_batch(x, u, n, k)
        C = qto_dcm(x[Q])
        F = np.zeros((n + 3 * k, n))
        F[:n] = np.eye(n)
        G = np.zeros((n + 3 * k, 3 * k))
        for i in range(k):
            r, a, e = u[3 * i:3 * i + 3]
            dirn = direction(np.array([r, a, e]))
            d = r * dirn
            ca, sa, ce, se = np.cos(a), np.sin(a), np.cos(e), np.sin(e)
            dd = np.column_stack([dirn, r * np.array([-ce * sa, ce * ca, 0.0]),
                                  r * np.array([-se * ca, -se * sa, ce])])
            rows = slice(n + 3 * i, n + 3 * i + 3)
            F[rows, TP] = np.eye(3)
            F[rows, TTH] = -C @ skew(d)
            G[rows, 3 * i:3 * i + 3] = C @ dd
        return F, G

    cov = np.kron(np.eye(k), obs_cov)
    return Transition(f, Noise(cov, np.kron(np.eye(k), psd_sqrt(obs_cov))), additive=False,
                      space=state_space(n_landmarks + k), jacobian=jacobian)


def _augmentation_jacobian_batch(x: Array, u: Array, n: int, k: int) -> tuple[Array, Array]:
    """:func:`augmentation_model`'s Jacobians for a batch of states (..., n) and
    observations (..., 3k)."""
    lead = x.shape[:-1]
    C = qto_dcm(x[..., Q])  # (..., 3, 3)
    F = np.zeros(lead + (n + 3 * k, n))
    F[..., :n, :] = np.eye(n)
    G = np.zeros(lead + (n + 3 * k, 3 * k))
    for i in range(k):
        r, a, e = u[..., 3 * i], u[..., 3 * i + 1], u[..., 3 * i + 2]
        dirn = direction(np.stack([r, a, e], axis=-1))  # (..., 3)
        d = r[..., None] * dirn
        ca, sa, ce, se = np.cos(a), np.sin(a), np.cos(e), np.sin(e)
        zero = np.zeros_like(a)
        dd = np.stack([dirn, r[..., None] * np.stack([-ce * sa, ce * ca, zero], axis=-1),
                       r[..., None] * np.stack([-se * ca, -se * sa, ce], axis=-1)], axis=-1)
        rows = slice(n + 3 * i, n + 3 * i + 3)
        F[..., rows, TP] = np.eye(3)
        F[..., rows, TTH] = -C @ skew(d)
        G[..., rows, 3 * i:3 * i + 3] = C @ dd
    return F, G
