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
from nav.quaternion import skew
from nav.spaces import UnitQuaternion
from nav.strapdown import attitudes, dcm_unit, mechanise

Array = NDArray[np.float64]
P, V, Q, BG, BA = slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(13, 16)
TP, TV, TTH, TBG, TBA = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)
DIM = 15
SPACE = Product([Euclidean(6), UnitQuaternion(), Euclidean(6)])
LAYOUT = InsLayout(DIM, bg=BG)
#: At most this many IMU samples per step of the error-state transition.
SUBSTEP_SAMPLES = 10

__all__ = ["DIM", "LAYOUT", "SPACE", "InsModel", "compose", "error_matrices",
           "error_transition", "ins_transition", "propagate", "psd_sqrt"]


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


def error_transition(x: Array, gyro: Array, accel: Array, dt: Array, model: InsModel
                     ) -> tuple[Array, Array]:
    """``(Φ, Q)`` of the 15-d error state over one epoch along the mean ``x`` (module doc)."""
    n = gyro.shape[0]
    starts = np.arange(0, n, SUBSTEP_SAMPLES)
    h = np.add.reduceat(dt, starts)
    w = gyro - x[BG]
    f = accel - x[BA]
    wm = np.add.reduceat(w * dt[:, None], starts) / h[:, None]
    fm = np.add.reduceat(f * dt[:, None], starts) / h[:, None]
    mid = np.minimum(starts + SUBSTEP_SAMPLES // 2, (np.append(starts[1:], n) + starts) // 2)
    C = dcm_unit(attitudes(x[Q], w, dt, model.earth_rate)[mid])
    qc = model.qc()
    Phis, Qks = step_matrices(error_matrices(C, wm, fm, model), h, qc)
    Phi, Qe = compose(Phis, Qks)
    return Phi, 0.5 * (Qe + Qe.T)


def ins_transition(x_mean: Array, gyro: Array, accel: Array, dt: Array, model: InsModel
                   ) -> Transition:
    """The epoch's prediction ``f(X, None)`` with additive tangent noise along the mean;
    EKF Jacobian :math:`\\Phi`."""
    dt = np.asarray(dt, dtype=np.float64)
    Phi, Qe = error_transition(x_mean, gyro, accel, dt, model)

    def f(X: Array, u: object) -> Array:
        return propagate(X, gyro, accel, dt, model)

    return Transition(f, Noise(Qe, psd_sqrt(Qe)), additive=True, jacobian=lambda x, u: Phi)
