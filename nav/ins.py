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
composed over the blocks (:func:`compose_sums`, equal to the pairwise :func:`compose`);
:math:`\Phi` is the EKF's Jacobian.
:math:`Q_c = \mathrm{diag}(0, N_a^2, N_g^2, q_{bg}, q_{ba})` (isotropic white noise, so
:math:`C N_a^2 C^\top = N_a^2 I`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from estimators import Euclidean, Noise, Product, Transition
from estimators.linalg import NotPositiveDefiniteError, chol, tria
from nav.gnss import InsLayout
from nav.imu_noise import ImuPsd
from nav.quaternion import dcm_to_q, qexp, qleft_matrix, qmul, skew
from nav.spaces import UnitQuaternion
from nav.strapdown import (
    attitudes,
    dcm_unit,
    gamma_coefficients,
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

__all__ = ["DIM", "LAYOUT", "SPACE", "InsModel", "Preintegrated", "compose", "compose_sums",
           "epoch_biases", "error_matrices", "error_transition", "ins_transition", "pad_epochs",
           "preintegrate", "preintegrate_stack", "preintegrates", "propagate",
           "propagate_preintegrated", "psd_sqrt"]


@dataclass(frozen=True)
class InsModel:
    """The IMU noise (:class:`~nav.imu_noise.ImuPsd`), gravity :math:`g^n` (3,) and the
    Earth rate :math:`\\omega_{ie}^n` (3,) or ``None``."""

    psd: ImuPsd
    gravity: Array
    earth_rate: Array | None = None

    def __post_init__(self) -> None:
        s = self.psd
        qc = np.concatenate([np.zeros(3), np.full(3, s.accel_density**2),
                             np.full(3, s.gyro_density**2), np.full(3, s.gyro_bias.psd()),
                             np.full(3, s.accel_bias.psd())])
        qc.flags.writeable = False
        object.__setattr__(self, "_qc", qc)
        F0 = np.zeros((DIM, DIM))
        idx = np.arange(3)
        F0[idx, 3 + idx] = 1.0
        if self.earth_rate is not None and np.any(self.earth_rate):
            F0[TV, TV] = -2.0 * skew(np.asarray(self.earth_rate, dtype=float))
        F0[6 + idx, 9 + idx] = -1.0
        F0[9 + idx, 9 + idx] = -s.gyro_bias.rate()
        F0[12 + idx, 12 + idx] = -s.accel_bias.rate()
        F0.flags.writeable = False
        object.__setattr__(self, "_F0", F0)

    def qc(self) -> Array:
        """Diagonal of :math:`GQ_cG^\\top` on the 15-d error state (read-only; built once)."""
        return self._qc  # type: ignore[attr-defined]

    def f0(self) -> Array:
        """The entries of :math:`F` that do not depend on the epoch: the position-velocity
        identity, the Earth rate, the attitude-gyro-bias coupling and the bias rates
        (read-only; built once)."""
        return self._F0  # type: ignore[attr-defined]


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


def epoch_biases(x: Array, tau: float, model: InsModel) -> Array:
    """The biases ``[b_g, b_a]`` (6,) of state ``x`` held over an epoch of length ``tau``:
    the Markov parts at their mid-epoch values (module docstring) - the biases the
    epoch's increments are preintegrated about."""
    dg, da = _decays(model, tau)
    return np.concatenate([x[BG] * np.sqrt(dg), x[BA] * np.sqrt(da)])


def preintegrates(model: InsModel, preintegrated: bool = True) -> bool:
    """:func:`ins_transition` moves the points by preintegrated increments (asked for, and
    no Earth rate in the model)."""
    return preintegrated and (model.earth_rate is None or not np.any(model.earth_rate))


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
    F = np.array(np.broadcast_to(model.f0(), w.shape[:-1] + (DIM, DIM)))
    F[..., TV, TTH] = -C @ skew(f)
    F[..., TV, TBA] = -C
    F[..., TTH, TTH] = -skew(w)
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


def compose_sums(Phis: Array, Qs: Array) -> tuple[Array, Array]:
    r""":func:`compose`'s ``(Φ, Q)`` as sums: with the suffix products
    :math:`\Psi_k = \Phi_{N-1}\cdots\Phi_{k+1}` (one log-depth scan),
    :math:`\Phi = \Psi_0\Phi_0` and :math:`Q = \sum_k \Psi_k Q_k \Psi_k^\top` (the same
    products, associated differently: fewer, larger batched calls)."""
    N = Phis.shape[-3]
    if N == 1:
        return Phis[..., 0, :, :], Qs[..., 0, :, :]
    P = Phis[..., ::-1, :, :].copy()  # P_i = Φ_{N-1} ··· Φ_{N-1-i} after the scan
    off = 1
    while off < N:
        P[..., off:, :, :] = P[..., :-off, :, :] @ P[..., off:, :, :]
        off *= 2
    Psi = P[..., N - 2::-1, :, :]  # Ψ_k = P_{N-2-k}, k = 0 .. N-2 (Ψ_{N-1} = I)
    Q = Qs[..., N - 1, :, :] + np.sum(Psi @ Qs[..., :N - 1, :, :] @ np.swapaxes(Psi, -1, -2),
                                      axis=-3)
    return P[..., N - 1, :, :], Q


def step_matrices(F: Array, h: Array, qc: Array) -> tuple[Array, Array]:
    """Per-step ``(Φ_k, Q_k)`` of continuous ``F`` (k, d, d) over ``h`` (k,) (module doc)."""
    hh = h[:, None, None]
    Fh = F * hh
    Fh2 = Fh @ Fh
    Phis = Fh + 0.5 * Fh2 + Fh2 @ Fh / 6.0
    Phis += np.eye(F.shape[-1])  # 1 on the diagonal, + 0 (exact) elsewhere
    FQ = F * qc
    FQt = np.swapaxes(FQ, -1, -2)
    Qks = 0.5 * (FQ + FQt) * hh**2 + (FQ @ np.swapaxes(F, -1, -2)) * (hh**3 / 3.0)
    Qks += np.diag(qc) * hh
    return Phis, Qks


@lru_cache(maxsize=64)
def _blocks(n: int) -> tuple[Array, Array]:
    """``(starts, mid)``: the first and the middle sample of each block of at most
    :data:`SUBSTEP_SAMPLES` of ``n`` samples (read-only)."""
    starts = np.arange(0, n, SUBSTEP_SAMPLES)
    mid = np.minimum(starts + SUBSTEP_SAMPLES // 2, (np.append(starts[1:], n) + starts) // 2)
    starts.flags.writeable = mid.flags.writeable = False
    return starts, mid


def error_transition(x: Array, gyro: Array, accel: Array, dt: Array, model: InsModel,
                     along: Array | None = None, *, relative: Array | None = None
                     ) -> tuple[Array, Array]:
    """``(Φ, Q)`` of the 15-d error state over one epoch along the mean ``x`` (module doc);
    ``along``: the mean's attitudes at every sample when already known, as quaternions
    (n + 1, 4) or matrices (n + 1, 3, 3); or ``relative``: those attitudes relative to
    the mean's at the start (n + 1, 3, 3), e.g. :attr:`Preintegrated.R_samples`."""
    starts, mid = _blocks(gyro.shape[0])
    h = np.add.reduceat(dt, starts)
    w = gyro - x[BG]
    f = accel - x[BA]
    m = np.add.reduceat(np.concatenate([w, f], axis=1) * dt[:, None], starts) / h[:, None]
    wm, fm = m[:, :3], m[:, 3:]
    if relative is not None:
        C = dcm_unit(x[Q]) @ relative[mid]
    else:
        if along is None:
            along = attitudes(x[Q], w, dt, model.earth_rate)
        C = along[mid] if along.ndim == 3 else dcm_unit(along[mid])
    qc = model.qc()
    Phis, Qks = step_matrices(error_matrices(C, wm, fm, model), h, qc)
    Phi, Qe = compose_sums(Phis, Qks)
    return Phi, 0.5 * (Qe + Qe.T)


@dataclass(frozen=True)
class Preintegrated:
    r"""Body-frame increments over an epoch from an identity start without gravity at the
    biases ``b`` = ``[b_g, b_a]`` (6,): ``dq`` (4,), ``dv``, ``dp`` (3,), their Jacobians
    ``J`` (9, 6) of ``[δθ, δv, δp]`` (:math:`\Delta q(b + \delta b) = \Delta q\otimes
    \mathrm{Exp}(J_\theta\delta b)`), the epoch length ``tau`` and the relative attitude
    matrices at every sample ``R_samples`` (n + 1, 3, 3)."""

    dq: Array
    dv: Array
    dp: Array
    J: Array
    b: Array
    tau: float
    R_samples: Array


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

    (:math:`J_{\cdot,<k}`: the sums over the samples before ``k``).

    Evaluated without per-sample matrix sums: the attitudes are prefix products of the
    matrices :math:`\mathrm{Exp}(\phi_k) = I + (1 - \theta_k^2 b_{1,k})[\phi_k]_\times +
    a_{1,k}[\phi_k]_\times^2` (log-depth); with
    :math:`T_j = R_{j+1}J_r(\phi_j)\Delta t_j` (so :math:`S_k = \sum_{j<k}T_j`) and
    :math:`\sigma_k = \sum_{j>k}\Delta t_j`, :math:`\sum_k [c_k\times]S_k =
    \sum_j [\bar c_j\times]T_j` with :math:`\bar c_j = \sum_{k>j}c_k` (one product)
    and :math:`\sum_k J_{\cdot,<k}\Delta t_k = \sum_k J_{\cdot,k}
    \sigma_k`, so each Jacobian block is one contraction over the samples;
    :math:`\Delta p = \sum_k c_k` with :math:`c_k = u_k\Delta t_k\sigma_k + w_k\Delta
    t_k^2`.  Computed as :func:`preintegrate_stack` of this one epoch."""
    return preintegrate_stack(*(np.asarray(a, dtype=np.float64)[None]
                                for a in (gyro, accel, dt, b)))[0]


def _quaternion(C: Array) -> Array:
    r"""``q`` of one rotation matrix: for a rotation under 120° (trace > 0)
    :math:`w = 	frac12\sqrt{1 + \mathrm{tr}\,C}`, :math:`v = (C_{21} - C_{12}, C_{02} -
    C_{20}, C_{10} - C_{01})/(4w)` in scalar arithmetic; otherwise
    :func:`nav.quaternion.dcm_to_q`."""
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = C.tolist()
    tr = c00 + c11 + c22
    if tr <= 0.0:
        return dcm_to_q(C)
    w = 0.5 * math.sqrt(1.0 + tr)
    k = 0.25 / w
    return np.array([w, (c21 - c12) * k, (c02 - c20) * k, (c10 - c01) * k])


def pad_epochs(pieces: Sequence[tuple[Array, Array, Array]]
               ) -> tuple[Array, Array, Array, NDArray[np.int64]]:
    """``(gyro (E, n, 3), accel (E, n, 3), dt (E, n), counts (E,))`` of epochs given as
    ``(gyro, accel, dt)`` pieces, each padded to the longest with zero-length samples."""
    counts = np.array([len(p[2]) for p in pieces], dtype=np.int64)
    n = int(counts.max())
    E = len(pieces)
    g, f, h = np.zeros((E, n, 3)), np.zeros((E, n, 3)), np.zeros((E, n))
    for e, (gy, ac, dt) in enumerate(pieces):
        k = len(dt)
        g[e, :k], f[e, :k], h[e, :k] = gy, ac, dt
    return g, f, h, counts


def _after(A: Array) -> Array:
    """Along axis 1: the sums of the rows after each row."""
    return np.cumsum(A[:, ::-1], axis=1)[:, ::-1] - A


def preintegrate_stack(gyro: Array, accel: Array, dt: Array, b: Array,
                       counts: NDArray[np.int64] | None = None) -> list[Preintegrated]:
    r""":func:`preintegrate` of ``E`` epochs at once, each about its own biases: ``gyro,
    accel`` (E, n, 3), ``dt`` (E, n), biases ``b`` (E, 6); ``counts`` (E,) the true sample
    counts (the attitudes ``R_samples`` are cut to ``count + 1``).  Each product over the
    samples is one numpy call for all the epochs, so a filter pays numpy's fixed cost once
    per batch instead of once per epoch.  Epochs of different lengths are padded with
    zero-length samples (:func:`pad_epochs`), which change nothing: :math:`\mathrm{Exp}(0)
    = I` and every sum is weighted by :math:`\Delta t_k = 0`.

    A filter preintegrating ahead does not know the biases of the later epochs yet; it
    takes its mean's at the batch's first epoch as the reference ``b`` of all of them
    (:class:`Preintegrated` carries it, and :func:`propagate_preintegrated` moves every
    point, the mean included, to first order in its bias offset from it)."""
    E, n = dt.shape
    b = np.asarray(b, dtype=np.float64)
    w = gyro - b[:, None, :3]
    f = accel - b[:, None, 3:]
    h = dt[..., None]
    phi = w * h
    t2 = np.einsum("eni,eni->en", phi, phi)
    a1, b1, _, b2 = (c[..., None, None] for c in gamma_coefficients(t2))
    K = skew(phi)
    eye = np.eye(3)
    K2 = phi[..., :, None] * phi[..., None, :] - t2[..., None, None] * eye
    R = (eye + (1.0 - t2[..., None, None] * b1) * K + a1 * K2).copy()
    off = 1
    while off < n:  # prefix products along the samples (log-depth)
        R[:, off:] = R[:, :-off] @ R[:, off:]
        off *= 2
    R = np.concatenate([np.broadcast_to(eye, (E, 1, 3, 3)), R], axis=1)  # (E, n + 1, 3, 3)
    Rk = R[:, :-1]
    RG = Rk @ np.concatenate([eye + a1 * K + b1 * K2, 0.5 * eye + b1 * K + b2 * K2], axis=-1)
    u = np.einsum("enij,enj->eni", RG[..., :3], f)
    wv = np.einsum("enij,enj->eni", RG[..., 3:], f)
    uh = u * h
    sig = _after(dt)
    c = uh * sig[..., None] + wv * h * h
    A = _after(np.concatenate([uh, c], axis=-1)) * h  # (E, n, 6)
    Y = (np.swapaxes(A, 1, 2) @ RG.reshape(E, n, 18)).reshape(E, 2, 3, 3, 6)[..., :3]
    M = np.stack([Y[:, :, 1, 2] - Y[:, :, 2, 1], Y[:, :, 2, 0] - Y[:, :, 0, 2],
                  Y[:, :, 0, 1] - Y[:, :, 1, 0]], axis=2)  # (E, 2, 3, 3)
    h2 = dt * dt
    G = (np.stack([dt, dt * sig, h2], axis=1) @ RG.reshape(E, n, 18)).reshape(E, 3, 3, 6)
    G1, G1s, G2h = G[:, 0, :, :3], G[:, 1, :, :3], G[:, 2, :, 3:]
    W = np.stack([0.5 * h2, h2 * (0.5 * sig + dt / 6.0)], axis=1)  # (E, 2, n)
    Z = (np.swapaxes(Rk.reshape(E, n, 9), 1, 2)
         @ (np.swapaxes(W, 1, 2)[..., None] * f[:, :, None, :]).reshape(E, n, 6))
    Z = Z.reshape(E, 3, 3, 2, 3)  # (e, i, j, g, m)
    Fs = np.stack([Z[:, :, 1, :, 2] - Z[:, :, 2, :, 1], Z[:, :, 2, :, 0] - Z[:, :, 0, :, 2],
                   Z[:, :, 0, :, 1] - Z[:, :, 1, :, 0]], axis=-1)  # (e, i, g, l)
    Fs = np.swapaxes(Fs, 1, 2)  # (e, g, i, l)
    J = np.zeros((E, 9, 6))
    J[:, 0:3, 0:3] = -np.swapaxes(R[:, -1], 1, 2) @ G1
    J[:, 3:6, 0:3] = M[:, 0] + Fs[:, 0]
    J[:, 3:6, 3:6] = -G1
    J[:, 6:9, 0:3] = M[:, 1] + Fs[:, 1]
    J[:, 6:9, 3:6] = -(G1s + G2h)
    dv, dp, tau = uh.sum(axis=1), c.sum(axis=1), dt.sum(axis=1)
    counts = np.full(E, n, dtype=np.int64) if counts is None else counts
    return [Preintegrated(_quaternion(R[e, -1]), dv[e], dp[e], J[e], b[e].copy(),
                          float(tau[e]), R[e, :int(counts[e]) + 1]) for e in range(E)]



def propagate_preintegrated(X: Array, pre: Preintegrated, model: InsModel) -> Array:
    r"""States ``X`` (m, 16) through an epoch by its increments (no Earth rate): with
    :math:`\delta b` each point's mid-epoch biases less ``pre.b``,
    :math:`q' = q\otimes\Delta q\,\mathrm{Exp}(J_\theta\delta b)`,
    :math:`v' = v + g\tau + C(q)(\Delta v + J_v\delta b)`,
    :math:`p' = p + v\tau + \tfrac12 g\tau^2 + C(q)(\Delta p + J_p\delta b)` - the
    mechanisation itself for the points at ``pre.b``, first order in the bias otherwise."""
    dg, da = _decays(model, pre.tau)
    decay = np.repeat([dg, da], 3)
    db = X[:, BG.start:BA.stop] * np.sqrt(decay) - pre.b
    d = db @ pre.J.T
    q = qmul(X[:, Q], qexp(d[:, :3]) @ qleft_matrix(pre.dq).T)
    m = len(X)
    qq = (X[:, Q, None] * X[:, None, Q]).reshape(m, 16)
    C = (qq @ _DCM_TABLE).reshape(m, 3, 3)  # C(q), quadratic in a unit q
    inc = np.empty((m, 3, 2))
    inc[:, :, 0] = pre.dv + d[:, 3:6]
    inc[:, :, 1] = pre.dp + d[:, 6:9]
    r = C @ inc
    g, tau = model.gravity, pre.tau
    Y = X.copy()
    Y[:, V] = X[:, V] + g * tau + r[:, :, 0]
    Y[:, P] = X[:, P] + X[:, V] * tau + 0.5 * g * tau * tau + r[:, :, 1]
    Y[:, Q] = q / np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]
    Y[:, BG.start:BA.stop] *= decay
    return Y


def _dcm_table() -> Array:
    r"""``T`` (16, 9) with :math:`C(q) = (q q^\top)_{\mathrm{flat}} T` for a unit ``q``:
    :math:`C_{00} = w^2 + x^2 - y^2 - z^2`, :math:`C_{01} = 2(xy - wz)`, ... (the
    homogeneous form of :func:`nav.strapdown.dcm_unit`; read-only)."""
    T = np.zeros((4, 4, 3, 3))
    w, x, y, z = range(4)
    for a, b, i, j, c in [
            (w, w, 0, 0, 1), (x, x, 0, 0, 1), (y, y, 0, 0, -1), (z, z, 0, 0, -1),
            (w, w, 1, 1, 1), (x, x, 1, 1, -1), (y, y, 1, 1, 1), (z, z, 1, 1, -1),
            (w, w, 2, 2, 1), (x, x, 2, 2, -1), (y, y, 2, 2, -1), (z, z, 2, 2, 1),
            (x, y, 0, 1, 2), (w, z, 0, 1, -2), (x, z, 0, 2, 2), (w, y, 0, 2, 2),
            (x, y, 1, 0, 2), (w, z, 1, 0, 2), (y, z, 1, 2, 2), (w, x, 1, 2, -2),
            (x, z, 2, 0, 2), (w, y, 2, 0, -2), (y, z, 2, 1, 2), (w, x, 2, 1, 2)]:
        T[a, b, i, j] = c
    T = T.reshape(16, 9)
    T.flags.writeable = False
    return T


_DCM_TABLE = _dcm_table()


def ins_transition(x_mean: Array, gyro: Array, accel: Array, dt: Array, model: InsModel, *,
                   preintegrated: bool = True, pre: Preintegrated | None = None) -> Transition:
    r"""The epoch's prediction ``f(X, None)`` with additive tangent noise along the mean;
    EKF Jacobian :math:`\Phi`.  Without Earth rate and with ``preintegrated`` the points
    move by the epoch's increments preintegrated once at the mean's biases
    (:func:`propagate_preintegrated`; ``pre``: these increments already computed, about
    the reference biases ``pre.b``, e.g. by :func:`preintegrate_stack`),
    else each point is mechanised (:func:`propagate`)."""
    dt = np.asarray(dt, dtype=np.float64)
    if preintegrates(model, preintegrated):
        if pre is None:
            pre = preintegrate(gyro, accel, dt, epoch_biases(x_mean, float(np.sum(dt)), model))
        Phi, Qe = error_transition(x_mean, gyro, accel, dt, model, relative=pre.R_samples)
        done = pre

        def f(X: Array, u: object) -> Array:
            return propagate_preintegrated(X, done, model)
    else:
        if pre is not None:
            raise ValueError("preintegrated increments given for a mechanised prediction "
                             "(Earth rate, or preintegrated=False)")
        Phi, Qe = error_transition(x_mean, gyro, accel, dt, model)

        def f(X: Array, u: object) -> Array:
            return propagate(X, gyro, accel, dt, model)

    return Transition(f, Noise.from_pd(Qe) or Noise(Qe, psd_sqrt(Qe)), additive=True,
                      jacobian=lambda x, u: Phi)
