r"""The INS/unit-quaternion (INS/UQ) model of [Fixed-wing EA-UKF] §5.3-5.4 with GNSS aiding.

State (ambient 19, tangent 18)
------------------------------
``[p (3), v (3), q_nb (4), ε_c (3), ε_m (3), ∇_m (3)]``: position as metres east, north,
up of the start point (the paper's latitude, longitude, height through the start point's
radii of curvature; on the flat-Earth local-level frame eq. 18 has constant radii),
velocity ENU (the paper's N, E, U), attitude on
:class:`nav.spaces.UnitQuaternion` (:math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)`,
the paper's quaternion error, eq. 16), gyro constant drift, gyro Markov drift and
accelerometer Markov drift (eq. 15, 18).

Prediction over one GNSS epoch of ``n`` IMU samples
---------------------------------------------------
Every point is mechanised (:func:`nav.strapdown.mechanise`) through the samples with
its own drifts removed, :math:`\tilde\omega - \varepsilon_c - \varepsilon_m` and
:math:`\tilde f - \nabla_m`, the Markov drifts held at their mid-epoch values
(:math:`e^{-\tau/2T}` of the start); then they decay by :math:`e^{-\tau/T}`.  The
noise is additive in the tangent, accumulated along the prior mean with the error
model (eq. 16-18 on the flat-Earth frame, no transport rate)

.. math::

    \dot{\delta p} = \delta v,\quad
    \dot{\delta v} = -C[f\times]\delta\theta - C\,\delta\nabla_m - 2[\omega_{ie}\times]\delta v
        - C n_a,\quad
    \dot{\delta\theta} = -[\omega\times]\delta\theta - \delta\varepsilon_c - \delta\varepsilon_m
        - n_g,

:math:`\dot{\delta\varepsilon_c} = 0`, :math:`\dot{\delta\varepsilon_m} = -\delta\varepsilon_m/T_a
+ w_1`, :math:`\dot{\delta\nabla_m} = -\delta\nabla_m/T_b + w_2`, discretised in steps of 0.1 s
and composed over the epoch (:func:`error_transition`); the product
:math:`\Phi` is the EKF's Jacobian.

Measurement: GNSS :math:`z = [p, v] + v_z` (linear, :math:`H = [I_6\ 0]`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from estimators import Euclidean, Measurement, Noise, Product, Transition
from nav.ins import compose as _compose
from nav.ins import psd_sqrt
from nav.quaternion import skew
from nav.spaces import UnitQuaternion
from nav.strapdown import attitudes, dcm_unit, mechanise
from slam.kinds.drone.models import ImuNoise

Array = NDArray[np.float64]
P, V, Q, EC, EM, NB = (slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(13, 16),
                       slice(16, 19))
TP, TV, TTH, TEC, TEM, TNB = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12),
                              slice(12, 15), slice(15, 18))
DIM = 18
SPACE = Product([Euclidean(6), UnitQuaternion(), Euclidean(9)])
#: IMU samples per step of the error-state transition (0.1 s at 100 Hz).
SUBSTEP_SAMPLES = 10

__all__ = ["SPACE", "InsNoise", "error_transition", "gnss_measurement", "ins_transition",
           "propagate"]


@dataclass(frozen=True)
class InsNoise(ImuNoise):
    """The densities (per √s) of :class:`~slam.kinds.drone.models.ImuNoise`, whose bias
    densities here drive the gyro and accelerometer Markov drifts, with their correlation
    times :math:`T_a, T_b` (s)."""

    gyro_time_s: float
    accel_time_s: float

    def qc(self) -> Array:
        """Diagonal of :math:`GQ_cG^\\top` on the 18-d error state: the 15-d vehicle
        diagonal with a zero block for the constant drift ε_c before the Markov drifts."""
        q = super().qc()
        return np.concatenate([q[:9], np.zeros(3), q[9:]])


def propagate(X: Array, gyro: Array, accel: Array, dt: float, gravity: Array,
              earth_rate: Array | None, decay: tuple[float, float]) -> Array:
    """Mechanise states ``X`` (m, 19) through one epoch's samples (n, 3) (module doc);
    the Markov drifts are removed at their mid-epoch values and decay by ``decay``."""
    mid = np.sqrt(decay)
    drift = X[:, EC] + X[:, EM] * mid[0]
    p, v, q = mechanise(X[:, P], X[:, V], X[:, Q], gyro[None] - drift[:, None],
                        accel[None] - (X[:, NB] * mid[1])[:, None], dt, gravity, earth_rate)
    Y = X.copy()
    Y[:, P], Y[:, V], Y[:, Q] = p, v, q
    Y[:, EM] *= decay[0]
    Y[:, NB] *= decay[1]
    return Y


def error_matrices(C: Array, w: Array, f: Array, earth_rate: Array | None,
                   noise: InsNoise) -> Array:
    """Continuous error-state matrices ``F`` (..., 18, 18) at attitude matrices ``C``,
    drift-corrected rates ``w`` and specific forces ``f`` (module docstring)."""
    F = np.zeros(w.shape[:-1] + (DIM, DIM))
    idx = np.arange(3)
    F[..., idx, 3 + idx] = 1.0
    F[..., TV, TTH] = -C @ skew(f)
    F[..., TV, TNB] = -C
    if earth_rate is not None and np.any(earth_rate):
        F[..., TV, TV] = -2.0 * skew(np.asarray(earth_rate, dtype=float))
    F[..., TTH, TTH] = -skew(w)
    F[..., 6 + idx, 9 + idx] = -1.0
    F[..., 6 + idx, 12 + idx] = -1.0
    F[..., 12 + idx, 12 + idx] = -1.0 / noise.gyro_time_s
    F[..., 15 + idx, 15 + idx] = -1.0 / noise.accel_time_s
    return F


def _block(n: int, most: int | None = None) -> int:
    """The largest divisor of ``n`` not above ``most`` (default :data:`SUBSTEP_SAMPLES`)."""
    most = SUBSTEP_SAMPLES if most is None else most
    return max(b for b in range(1, min(n, most) + 1) if n % b == 0)


def error_transition(x: Array, gyro: Array, accel: Array, dt: float,
                     earth_rate: Array | None, noise: InsNoise) -> tuple[Array, Array]:
    r"""``(Φ, Q)`` of the 18-d error state over one epoch along the mean ``x``.

    The epoch is cut into steps of ``b`` samples (:data:`SUBSTEP_SAMPLES`, h = b Δt);
    each step uses the mean rate and specific force over its samples and the attitude at
    its middle: :math:`\Phi_k = \sum_{i \le 3} (F_k h)^i / i!`,
    :math:`Q_k = Q_c h + \tfrac12(F_kQ_c + Q_cF_k^\top)h^2 + \tfrac13 F_kQ_cF_k^\top h^3`,
    composed over the steps (the mean itself is mechanised sample by sample)."""
    n = gyro.shape[0]
    b = _block(n)
    h = b * dt
    w = gyro - x[EC] - x[EM]
    f = accel - x[NB]
    C = dcm_unit(attitudes(x[Q], w, dt, earth_rate)[b // 2::b][: n // b])
    F = error_matrices(C, w.reshape(-1, b, 3).mean(axis=1), f.reshape(-1, b, 3).mean(axis=1),
                       earth_rate, noise)
    Fh = F * h
    Fh2 = Fh @ Fh
    Phis = Fh + 0.5 * Fh2 + Fh2 @ Fh / 6.0
    Phis[:, np.arange(DIM), np.arange(DIM)] += 1.0
    qc = noise.qc()
    FQ = F * qc
    Qks = 0.5 * (FQ + np.swapaxes(FQ, -1, -2)) * h**2 + (FQ @ np.swapaxes(F, -1, -2)) * (
        h**3 / 3.0)
    Qks[:, np.arange(DIM), np.arange(DIM)] += qc * h
    Phi, Qe = _compose(Phis, Qks)
    return Phi, 0.5 * (Qe + Qe.T)


def ins_transition(x_mean: Array, gyro: Array, accel: Array, dt: float, gravity: Array,
                   earth_rate: Array | None, noise: InsNoise) -> Transition:
    """The epoch's prediction ``f(X, None)`` with additive tangent noise along the mean;
    EKF Jacobian :math:`\\Phi` (with the Markov decay of the epoch)."""
    tau = gyro.shape[0] * dt
    decay = (math.exp(-tau / noise.gyro_time_s), math.exp(-tau / noise.accel_time_s))
    Phi, Qe = error_transition(x_mean, gyro, accel, dt, earth_rate, noise)

    def f(X: Array, u: object) -> Array:
        return propagate(X, gyro, accel, dt, gravity, earth_rate, decay)

    return Transition(f, Noise(Qe, psd_sqrt(Qe)), additive=True, jacobian=lambda x, u: Phi)


def gnss_measurement(horizontal_sigma: float, vertical_sigma: float, velocity_sigma: float
                     ) -> Measurement:
    """GNSS position + velocity, :math:`z = [p, v] + v_z` (module docstring)."""
    sig = np.array([horizontal_sigma, horizontal_sigma, vertical_sigma, *[velocity_sigma] * 3])
    H = np.hstack([np.eye(6), np.zeros((6, DIM - 6))])
    return Measurement(lambda X: X[:, :6], Noise.from_sigmas(sig), jacobian=lambda x: H)
