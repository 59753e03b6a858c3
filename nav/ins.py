r"""A 15-state strapdown INS for GNSS aiding, driven by time stamps (per-sample intervals).

State (ambient 16, tangent 15)
------------------------------
``[p (3), v (3), q_nb (4), b_g (3), b_a (3)]`` in a local-level ENU frame, FLU body axes
(:mod:`nav.strapdown`); the attitude on :class:`nav.spaces.UnitQuaternion`
(:math:`q = \hat q\otimes\mathrm{Exp}(\delta\theta)`); the gyro and accelerometer biases
each a :class:`nav.imu_noise.BiasProcess` (random walk, first-order Markov, or both).

Prediction through the IMU samples of one epoch
-----------------------------------------------
Reading ``k`` is held over its own interval :math:`\Delta t_k` (any number of samples per
epoch, any spacing).  Every point is mechanised (:func:`nav.strapdown.mechanise`) with
its own biases removed, the Markov parts held at their mid-epoch values
(:math:`\phi^{1/2}` of the start), which then decay by :math:`\phi = e^{-\tau/T}`.  The
noise is additive in the tangent, accumulated along the prior mean with the error model

.. math::

    \dot{\delta p} = \delta v,\quad
    \dot{\delta v} = -C[f\times]\delta\theta - C\,\delta b_a - 2[\omega_{ie}\times]\delta v
        - C n_a,\quad
    \dot{\delta\theta} = -[\omega\times]\delta\theta - \delta b_g - n_g,\quad
    \dot{\delta b} = -\delta b/T + w,

discretised per block of at most :data:`SUBSTEP_SAMPLES` samples (the block's
interval-weighted mean rate and specific force, the attitude at its middle sample):
:math:`\Phi_k = \sum_{i\le3}(F_kh_k)^i/i!`,
:math:`Q_k = Q_ch_k + \tfrac12(F_kQ_c + Q_cF_k^\top)h_k^2 + \tfrac13F_kQ_cF_k^\top h_k^3`,
composed over the blocks (:func:`compose`); :math:`\Phi` is the EKF's Jacobian.
:math:`Q_c = \mathrm{diag}(0, N_a^2, N_g^2, q_{bg}, q_{ba})` (isotropic white noise, so
:math:`C N_a^2 C^\top = N_a^2 I`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from estimators import Euclidean, Noise, Product, Transition
from estimators.linalg import NotPositiveDefiniteError, chol, tria
from nav.gnss import InsLayout
from nav.imu_noise import ImuPsd
from nav.quaternion import _PRODUCT_TABLE, qexp, skew
from nav.spaces import UnitQuaternion
from nav.strapdown import (
    _qexp,
    attitudes,
    dcm_unit,
    gamma_coefficients,
    hamilton,
    mechanise,
)

Array = NDArray[np.float64]
P, V, Q, BG, BA = slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(13, 16)
TP, TV, TTH, TBG, TBA = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)
DIM = 15
SPACE = Product([Euclidean(6), UnitQuaternion(), Euclidean(6)])
LAYOUT = InsLayout(DIM, bg=BG)
#: At most this many IMU samples per step of the error-state transition.
SUBSTEP_SAMPLES = 10

__all__ = ["DIM", "LAYOUT", "SPACE", "InsModel", "Preintegrated", "compose", "error_matrices",
           "error_transition", "ins_transition", "preintegrate", "propagate",
           "propagate_preintegrated", "psd_sqrt"]


@dataclass(frozen=True)
class InsModel:
    """The IMU noise (:class:`~nav.imu_noise.ImuPsd`), gravity :math:`g^n` (3,) and the
    Earth rate :math:`\\omega_{ie}^n` (3,) or ``None``."""

    psd: ImuPsd
    gravity: Array
    earth_rate: Array | None = None

    def qc(self) -> Array:
        """Diagonal of :math:`GQ_cG^\\top` on the 15-d error state."""
        s = self.psd
        return np.concatenate([np.zeros(3), np.full(3, s.accel_density**2),
                               np.full(3, s.gyro_density**2), np.full(3, s.gyro_bias.psd()),
                               np.full(3, s.accel_bias.psd())])


def psd_sqrt(C: Array) -> Array:
    """A lower-triangular factor of a symmetric positive semi-definite matrix (a batch of
    them: leading axes)."""
    C = 0.5 * (C + np.swapaxes(C, -1, -2))
    try:
        return chol(C)
    except NotPositiveDefiniteError:
        w, U = np.linalg.eigh(C)
        return tria(U * np.sqrt(np.clip(w, 0.0, None))[..., None, :])


def _decays(model: InsModel, tau: float) -> tuple[float, float]:
    return model.psd.gyro_bias.decay(tau), model.psd.accel_bias.decay(tau)


def propagate(X: Array, gyro: Array, accel: Array, dt: Array, model: InsModel) -> Array:
    """Mechanise states ``X`` (m, 16) through one epoch's samples ``gyro, accel`` (n, 3)
    with intervals ``dt`` (n,) (module docstring)."""
    dg, da = _decays(model, float(np.sum(dt)))
    bg, ba = X[:, BG] * np.sqrt(dg), X[:, BA] * np.sqrt(da)
    p, v, q = mechanise(X[:, P], X[:, V], X[:, Q], gyro[None] - bg[:, None],
                        accel[None] - ba[:, None], dt, model.gravity, model.earth_rate)
    Y = X.copy()
    Y[:, P], Y[:, V], Y[:, Q] = p, v, q
    Y[:, BG] *= dg
    Y[:, BA] *= da
    return Y


def error_matrices(C: Array, w: Array, f: Array, model: InsModel) -> Array:
    """Continuous error-state matrices ``F`` (..., 15, 15) at attitude matrices ``C``,
    bias-corrected rates ``w`` and specific forces ``f`` (module docstring)."""
    F = np.zeros(w.shape[:-1] + (DIM, DIM))
    idx = np.arange(3)
    F[..., idx, 3 + idx] = 1.0
    F[..., TV, TTH] = -C @ skew(f)
    F[..., TV, TBA] = -C
    if model.earth_rate is not None and np.any(model.earth_rate):
        F[..., TV, TV] = -2.0 * skew(np.asarray(model.earth_rate, dtype=float))
    F[..., TTH, TTH] = -skew(w)
    F[..., 6 + idx, 9 + idx] = -1.0
    F[..., 9 + idx, 9 + idx] = -model.psd.gyro_bias.rate()
    F[..., 12 + idx, 12 + idx] = -model.psd.accel_bias.rate()
    return F


def compose(Phis: Array, Qs: Array) -> tuple[Array, Array]:
    """Compose per-step ``(Φ_k, Q_k)`` (axis -3 is time) into the epoch's ``(Φ, Q)``:
    pairwise, ``(Φ_b Φ_a, Φ_b Q_a Φ_bᵀ + Q_b)`` for ``a`` before ``b`` (log-depth)."""
    while Phis.shape[-3] > 1:
        n = Phis.shape[-3]
        even = n - n % 2
        Pa, Pb = Phis[..., 0:even:2, :, :], Phis[..., 1:even:2, :, :]
        Qa, Qb = Qs[..., 0:even:2, :, :], Qs[..., 1:even:2, :, :]
        P = Pb @ Pa
        Qn = Pb @ Qa @ np.swapaxes(Pb, -1, -2) + Qb
        if n % 2:
            P = np.concatenate([P, Phis[..., -1:, :, :]], axis=-3)
            Qn = np.concatenate([Qn, Qs[..., -1:, :, :]], axis=-3)
        Phis, Qs = P, Qn
    return Phis[..., 0, :, :], Qs[..., 0, :, :]


def step_matrices(F: Array, h: Array, qc: Array) -> tuple[Array, Array]:
    """Per-step ``(Φ_k, Q_k)`` of continuous ``F`` (k, d, d) over ``h`` (k,) (module doc)."""
    d = F.shape[-1]
    hh = h[:, None, None]
    Fh = F * hh
    Fh2 = Fh @ Fh
    Phis = Fh + 0.5 * Fh2 + Fh2 @ Fh / 6.0
    Phis[:, np.arange(d), np.arange(d)] += 1.0
    FQ = F * qc
    Qks = 0.5 * (FQ + np.swapaxes(FQ, -1, -2)) * hh**2 + (FQ @ np.swapaxes(F, -1, -2)) * (
        hh**3 / 3.0)
    Qks[:, np.arange(d), np.arange(d)] += qc * h[:, None]
    return Phis, Qks


def error_transition(x: Array, gyro: Array, accel: Array, dt: Array, model: InsModel,
                     along: Array | None = None) -> tuple[Array, Array]:
    """``(Φ, Q)`` of the 15-d error state over one epoch along the mean ``x`` (module doc);
    ``along``: the mean's attitudes at every sample (n + 1, 4) when already known."""
    n = gyro.shape[0]
    starts = np.arange(0, n, SUBSTEP_SAMPLES)
    h = np.add.reduceat(dt, starts)
    w = gyro - x[BG]
    f = accel - x[BA]
    wm = np.add.reduceat(w * dt[:, None], starts) / h[:, None]
    fm = np.add.reduceat(f * dt[:, None], starts) / h[:, None]
    mid = np.minimum(starts + SUBSTEP_SAMPLES // 2, (np.append(starts[1:], n) + starts) // 2)
    if along is None:
        along = attitudes(x[Q], w, dt, model.earth_rate)
    C = dcm_unit(along[mid])
    qc = model.qc()
    Phis, Qks = step_matrices(error_matrices(C, wm, fm, model), h, qc)
    Phi, Qe = compose(Phis, Qks)
    return Phi, 0.5 * (Qe + Qe.T)


@dataclass(frozen=True)
class Preintegrated:
    r"""Body-frame increments over an epoch from an identity start without gravity at the
    biases ``b`` = ``[b_g, b_a]`` (6,): ``dq`` (4,), ``dv``, ``dp`` (3,), their Jacobians
    ``J`` (9, 6) of ``[δθ, δv, δp]`` (:math:`\Delta q(b + \delta b) = \Delta q\otimes
    \mathrm{Exp}(J_\theta\delta b)`), the epoch length ``tau`` and the relative attitudes at
    every sample ``q_samples`` (n + 1, 4)."""

    dq: Array
    dv: Array
    dp: Array
    J: Array
    b: Array
    tau: float
    q_samples: Array


def _qmul_table(p: Array, q: Array) -> Array:
    """Hamilton products of (n, 4) rows by the product table (one outer product and one
    matrix product: fewer array operations than :func:`nav.strapdown.hamilton`)."""
    return (p[:, :, None] * q[:, None, :]).reshape(-1, 16) @ _PRODUCT_TABLE


def _scan(E: Array) -> Array:
    """Prefix products ``[1, E_0, E_0 E_1, ...]`` (n + 1, 4) of one series (log-depth)."""
    out = E.copy()
    off = 1
    while off < len(out):
        out = np.concatenate([out[:off], _qmul_table(out[:-off], out[off:])])
        off *= 2
    return np.concatenate([[[1.0, 0.0, 0.0, 0.0]], out])


def _before(A: Array) -> Array:
    """Sums of the rows before each row: ``[0, A_0, A_0 + A_1, ...]`` without the total."""
    return np.concatenate([np.zeros((1,) + A.shape[1:]), np.cumsum(A, axis=0)[:-1]])


def preintegrate(gyro: Array, accel: Array, dt: Array, b: Array) -> Preintegrated:
    r""":class:`Preintegrated` of one epoch's samples at biases ``b``: the mechanisation
    of :mod:`nav.strapdown` from the identity (so :math:`\Delta q, \Delta v, \Delta p` are
    its increments) and the bias Jacobians to second order in the interval (the
    :math:`\Gamma` series to their first terms), with
    :math:`R_k` the attitude at sample ``k``, :math:`J_r` the right Jacobian of
    :math:`\phi_k = \omega_k\Delta t_k`, :math:`S_k = \sum_{j<k} R_{j+1}J_r(\phi_j)\Delta t_j`,
    :math:`u_k = R_k\Gamma_1(\phi_k)f_k`, :math:`w_k = R_k\Gamma_2(\phi_k)f_k`:

    .. math::

        J_{\theta g} = -R_n^\top S_n,\quad
        J_{vg} = \sum_k \big([u_k\times]S_k + \tfrac12 R_k[f_k\times]\Delta t_k\big)
            \Delta t_k,\quad
        J_{va} = -\sum_k R_k\Gamma_1\Delta t_k,

        J_{pg} = \sum_k \big(J_{vg,<k}\Delta t_k + ([w_k\times]S_k
            + \tfrac16 R_k[f_k\times]\Delta t_k)\Delta t_k^2\big),\quad
        J_{pa} = \sum_k \big(J_{va,<k}\Delta t_k - R_k\Gamma_2\Delta t_k^2\big)

    (:math:`J_{\cdot,<k}`: the sums over the samples before ``k``)."""
    w = gyro - b[:3]
    f = accel - b[3:]
    h = dt[:, None]
    hh = dt[:, None, None]
    phi = w * h
    Q = _scan(_qexp(phi))
    Q = Q / np.linalg.norm(Q, axis=1, keepdims=True)
    R = dcm_unit(Q)  # (n + 1, 3, 3)
    a1, b1, a2, b2 = gamma_coefficients(np.sum(phi * phi, axis=1))
    K = skew(phi)
    K2 = K @ K
    eye = np.eye(3)
    G1 = eye + a1[:, None, None] * K + b1[:, None, None] * K2
    G2 = 0.5 * eye + a2[:, None, None] * K + b2[:, None, None] * K2
    Jr = eye - a1[:, None, None] * K + b1[:, None, None] * K2
    RG1, RG2 = R[:-1] @ G1, R[:-1] @ G2
    u = np.einsum("nij,nj->ni", RG1, f)
    wv = np.einsum("nij,nj->ni", RG2, f)
    V = np.concatenate([np.zeros((1, 3)), np.cumsum(u * h, axis=0)])
    dp = np.sum(V[:-1] * h + wv * h * h, axis=0)
    terms = R[1:] @ Jr * hh
    S = _before(terms)
    Fk = skew(f)
    Jvg_k = (skew(u) @ S + 0.5 * R[:-1] @ Fk * hh) * hh
    Jva_k = -RG1 * hh
    J = np.zeros((9, 6))
    J[0:3, 0:3] = -R[-1].T @ terms.sum(axis=0)
    J[3:6, 0:3] = Jvg_k.sum(axis=0)
    J[3:6, 3:6] = Jva_k.sum(axis=0)
    J[6:9, 0:3] = np.sum(_before(Jvg_k) * hh + (skew(wv) @ S + R[:-1] @ Fk * hh / 6.0)
                         * hh**2, axis=0)
    J[6:9, 3:6] = np.sum(_before(Jva_k) * hh - RG2 * hh**2, axis=0)
    return Preintegrated(Q[-1], V[-1], dp, J, np.asarray(b, dtype=float).copy(),
                         float(dt.sum()), Q)


def propagate_preintegrated(X: Array, pre: Preintegrated, model: InsModel) -> Array:
    r"""States ``X`` (m, 16) through an epoch by its increments (no Earth rate): with
    :math:`\delta b` each point's mid-epoch biases less ``pre.b``,
    :math:`q' = q\otimes\Delta q\,\mathrm{Exp}(J_\theta\delta b)`,
    :math:`v' = v + g\tau + C(q)(\Delta v + J_v\delta b)`,
    :math:`p' = p + v\tau + \tfrac12 g\tau^2 + C(q)(\Delta p + J_p\delta b)` - the
    mechanisation itself for the points at ``pre.b``, first order in the bias otherwise."""
    dg, da = _decays(model, pre.tau)
    db = np.concatenate([X[:, BG] * np.sqrt(dg), X[:, BA] * np.sqrt(da)], axis=1) - pre.b
    d = db @ pre.J.T
    q = hamilton(X[:, Q], hamilton(pre.dq[None], qexp(d[:, :3])))
    C = dcm_unit(X[:, Q])
    g, tau = model.gravity, pre.tau
    Y = X.copy()
    Y[:, V] = X[:, V] + g * tau + np.einsum("mij,mj->mi", C, pre.dv + d[:, 3:6])
    Y[:, P] = X[:, P] + X[:, V] * tau + 0.5 * g * tau * tau + np.einsum(
        "mij,mj->mi", C, pre.dp + d[:, 6:9])
    Y[:, Q] = q / np.linalg.norm(q, axis=1, keepdims=True)
    Y[:, BG] *= dg
    Y[:, BA] *= da
    return Y


def ins_transition(x_mean: Array, gyro: Array, accel: Array, dt: Array, model: InsModel, *,
                   preintegrated: bool = True) -> Transition:
    r"""The epoch's prediction ``f(X, None)`` with additive tangent noise along the mean;
    EKF Jacobian :math:`\Phi`.  Without Earth rate and with ``preintegrated`` the points
    move by the epoch's increments preintegrated once at the mean's biases
    (:func:`propagate_preintegrated`), else each point is mechanised (:func:`propagate`)."""
    dt = np.asarray(dt, dtype=np.float64)
    if preintegrated and (model.earth_rate is None or not np.any(model.earth_rate)):
        dg, da = _decays(model, float(np.sum(dt)))
        pre = preintegrate(gyro, accel, dt, np.concatenate([x_mean[BG] * np.sqrt(dg),
                                                            x_mean[BA] * np.sqrt(da)]))
        Phi, Qe = error_transition(x_mean, gyro, accel, dt, model,
                                   hamilton(x_mean[Q][None], pre.q_samples))

        def f(X: Array, u: object) -> Array:
            return propagate_preintegrated(X, pre, model)
    else:
        Phi, Qe = error_transition(x_mean, gyro, accel, dt, model)

        def f(X: Array, u: object) -> Array:
            return propagate(X, gyro, accel, dt, model)

    return Transition(f, Noise(Qe, psd_sqrt(Qe)), additive=True, jacobian=lambda x, u: Phi)
