r"""Strapdown inertial mechanisation in a local-level East-North-Up frame.

Frames and the flat-Earth approximation
---------------------------------------
The navigation frame ``n`` is a fixed local-level ENU frame (x east, y north, z up) on a
flat Earth; the body frame ``b`` is forward-left-up; the attitude is the Hamilton unit
quaternion ``q_nb`` (see :mod:`nav.quaternion`).  Over a 100 m field and a few minutes of
flight the flat-Earth local-level frame is adequate: the Earth's curvature moves the
local vertical by 1.6e-5 rad per 100 m and the transport rate at 3 m/s is 5e-7 rad/s,
both far below a MEMS IMU's noise, so gravity is the constant vector
:math:`g^n = [0, 0, -g]`.  The Earth's rotation :math:`\omega_{ie}^n` (7.3e-5 rad/s,
about the size of a MEMS gyro's bias) is optional and off by default
(:func:`earth_rate_enu`); when on, the navigation frame turns with the Earth and the
velocity equation gains the Coriolis term :math:`-2\,\omega_{ie}^n \times v`.

The discrete model
------------------
An IMU sample ``k`` reports the body angular rate :math:`\omega_k` and the specific force
:math:`f_k` as their averages over :math:`[t_k, t_k + \Delta t]` (a delta-angle and a
delta-velocity divided by :math:`\Delta t`); both are held constant **in the body frame**
over the interval.  With :math:`\phi_k = \omega_k \Delta t`:

.. math::

    q_{k+1} &= \mathrm{Exp}(-\omega_{ie}^n \Delta t) \otimes q_k \otimes \mathrm{Exp}(\phi_k),

    v_{k+1} &= v_k + C(q_k)\,\Gamma_1(\phi_k)\,f_k\,\Delta t + a^n_k\,\Delta t,

    p_{k+1} &= p_k + v_k\,\Delta t + C(q_k)\,\Gamma_2(\phi_k)\,f_k\,\Delta t^2
              + \tfrac12\,a^n_k\,\Delta t^2,

with :math:`a^n_k = g^n - 2\,\omega_{ie}^n \times v_k` and the closed-form integrals of
the body rotation over the interval

.. math::

    \Gamma_1(\phi) = \int_0^1 \mathrm{Exp}(s\phi)\,ds
        = I + \frac{1 - \cos\theta}{\theta^2}[\phi]_\times
            + \frac{\theta - \sin\theta}{\theta^3}[\phi]_\times^2,

    \Gamma_2(\phi) = \int_0^1\!\!\int_0^s \mathrm{Exp}(r\phi)\,dr\,ds
        = \tfrac12 I + \frac{\theta - \sin\theta}{\theta^3}[\phi]_\times
            + \frac{\theta^2/2 + \cos\theta - 1}{\theta^4}[\phi]_\times^2,

:math:`\theta = \lVert\phi\rVert` (Taylor series below ``SERIES_BELOW``).  The attitude
step is the closed-form quaternion increment (:func:`nav.quaternion.qpropagate`);
velocity and position are the exact integrals of the piecewise-constant body-frame
model, so without Earth rate the scheme is exact for any motion whose body rate and
specific force are constant over each interval - a constant turn, a constant climb, a
banked helix - up to round-off.  With Earth rate on, the nav-frame rotation inside one
interval (:math:`|\omega_{ie}|\Delta t \approx 7\cdot10^{-7}` rad) is applied at its end
and the Coriolis term is held at :math:`v_k` (a first-order scheme; the simulator uses the
same equations, so a noise-free log is still reproduced exactly).

:func:`ideal_imu` inverts the model: from sampled attitudes and velocities it returns the
readings that make :func:`mechanise` reproduce them (attitude and velocity exactly at
the samples, position to :math:`O(\Delta t^3)` per interval).

Everything is vectorised over points (rows) and samples; attitudes are accumulated by
a log-depth parallel prefix product of the increments.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .quaternion import qconj, qexp, qlog, qmul, qrotate, skew

Array = NDArray[np.float64]

#: Standard gravity (m/s^2).
G0 = 9.80665
#: Earth's rotation rate (rad/s, sidereal).
EARTH_RATE = 7.2921150e-5
#: Below this rotation angle (rad) per interval the Γ coefficients use Taylor series.
SERIES_BELOW = 1e-2

__all__ = [
    "EARTH_RATE",
    "G0",
    "earth_rate_enu",
    "gamma_coefficients",
    "gamma_matrices",
    "gravity_enu",
    "attitudes",
    "dcm_unit",
    "hamilton",
    "ideal_imu",
    "mechanise",
    "prefix_products",
]


def gravity_enu(g: float = G0) -> Array:
    """Gravity in the ENU frame, ``[0, 0, -g]``."""
    return np.array([0.0, 0.0, -float(g)])


def earth_rate_enu(latitude_rad: float) -> Array:
    r"""Earth rate in the local ENU frame, :math:`\Omega\,[0, \cos L, \sin L]`."""
    return EARTH_RATE * np.array([0.0, math.cos(latitude_rad), math.sin(latitude_rad)])


def gamma_coefficients(theta2: ArrayLike) -> tuple[Array, Array, Array, Array]:
    r"""Coefficients ``(a1, b1, a2, b2)`` of :math:`\Gamma_1 = I + a_1[\phi]_\times +
    b_1[\phi]_\times^2` and :math:`\Gamma_2 = \tfrac12 I + a_2[\phi]_\times + b_2[\phi]_\times^2`
    for :math:`\theta^2 = \lVert\phi\rVert^2` (note :math:`a_2 = b_1`).

    Series (three terms; truncation below 1e-19 relative for
    :math:`\theta <` ``SERIES_BELOW``):
    :math:`a_1 = 1/2 - \theta^2/24 + \theta^4/720`,
    :math:`b_1 = 1/6 - \theta^2/120 + \theta^4/5040`,
    :math:`b_2 = 1/24 - \theta^2/720 + \theta^4/40320`.
    """
    t2 = np.asarray(theta2, dtype=np.float64)
    small = t2 < SERIES_BELOW**2
    if np.all(small):
        t4 = t2 * t2
        b1 = 1.0 / 6.0 - t2 / 120.0 + t4 / 5040.0
        return (0.5 - t2 / 24.0 + t4 / 720.0, b1, b1,
                1.0 / 24.0 - t2 / 720.0 + t4 / 40320.0)
    t = np.sqrt(np.where(small, 1.0, t2))
    s, c = np.sin(t), np.cos(t)
    tt = np.where(small, 1.0, t2)
    a1 = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - c) / tt)
    b1 = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0, (t - s) / (tt * t))
    b2 = np.where(small, 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0,
                  (0.5 * tt + c - 1.0) / (tt * tt))
    return a1, b1, b1, b2


def _cross(a: Array, b: Array) -> Array:
    """Broadcasting cross product of ``(..., 3)`` arrays (component form, fast)."""
    a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2]
    b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1], axis=-1)


def hamilton(p: Array, q: Array) -> Array:
    """Hamilton product in component form (equals :func:`nav.quaternion.qmul`; several
    times faster on long series of samples)."""
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def _qexp(phi: Array) -> Array:
    """:func:`nav.quaternion.qexp` of rotation vectors; a pure series (no trigonometry)
    when every angle is below ``SERIES_BELOW`` (truncation below 1e-20)."""
    t2 = np.sum(phi * phi, axis=-1)
    out = np.empty(phi.shape[:-1] + (4,))
    if np.all(t2 < SERIES_BELOW**2):
        t4 = t2 * t2
        out[..., 0] = 1.0 - t2 / 8.0 + t4 / 384.0 - t4 * t2 / 46080.0
        k = 0.5 - t2 / 48.0 + t4 / 3840.0 - t4 * t2 / 645120.0
    else:
        t = np.sqrt(t2)
        small = t < 1e-4
        safe = np.where(small, 1.0, t)
        k = np.where(small, 0.5 - t2 / 48.0 + t2 * t2 / 3840.0, np.sin(0.5 * safe) / safe)
        out[..., 0] = np.cos(0.5 * t)
    out[..., 1:] = k[..., None] * phi
    return out


def dcm_unit(q: Array) -> Array:
    """``C(q)`` of unit quaternions, (..., 3, 3) (no normalisation; fast component form;
    one quaternion in scalar arithmetic, the same operations)."""
    one = q.ndim == 1
    w, x, y, z = q.tolist() if one else (q[..., 0], q[..., 1], q[..., 2], q[..., 3])
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    rows = (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy),
            2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx),
            2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy))
    if one:
        return np.array(rows).reshape(3, 3)
    C = np.empty(q.shape[:-1] + (9,))
    for k, entry in enumerate(rows):
        C[..., k] = entry
    return C.reshape(q.shape[:-1] + (3, 3))


def _apply_gammas(phi: Array, f: Array) -> tuple[Array, Array]:
    """``(Γ1(φ) f, Γ2(φ) f)`` for broadcast ``(..., 3)`` arrays."""
    a1, b1, a2, b2 = gamma_coefficients(np.sum(phi * phi, axis=-1))
    pf = _cross(phi, f)
    ppf = _cross(phi, pf)
    g1 = f + a1[..., None] * pf + b1[..., None] * ppf
    g2 = 0.5 * f + a2[..., None] * pf + b2[..., None] * ppf
    return g1, g2


def gamma_matrices(phi: ArrayLike) -> tuple[Array, Array]:
    r""":math:`\Gamma_1(\phi)` and :math:`\Gamma_2(\phi)` as ``(..., 3, 3)`` matrices."""
    phi = np.asarray(phi, dtype=np.float64)
    a1, b1, a2, b2 = gamma_coefficients(np.sum(phi * phi, axis=-1))
    K = skew(phi)
    K2 = K @ K
    eye = np.eye(3)
    G1 = eye + a1[..., None, None] * K + b1[..., None, None] * K2
    G2 = 0.5 * eye + a2[..., None, None] * K + b2[..., None, None] * K2
    return G1, G2


_RIGHT_IDX = np.array([[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]])
_RIGHT_SIGN = np.array([[1.0, -1.0, -1.0, -1.0], [1.0, 1.0, 1.0, -1.0],
                        [1.0, -1.0, 1.0, 1.0], [1.0, 1.0, -1.0, 1.0]])


def _right_matrix(e: Array) -> Array:
    """4x4 matrices ``R(e)`` with ``q ⊗ e = R(e) q``, shape (..., 4, 4)."""
    return e[..., _RIGHT_IDX] * _RIGHT_SIGN


def prefix_products(E: Array, q0: Array | None = None) -> Array:
    r"""Ordered prefix products along axis ``-2``:
    ``out[..., k, :] = q0 ⊗ E[..., 0, :] ⊗ ⋯ ⊗ E[..., k-1, :]``, ``k = 0..n``
    (``q0`` defaults to the identity), shape (..., n + 1, 4).

    Long series (``n > 64``) use a Hillis-Steele scan (:math:`\lceil\log_2 n\rceil`
    batched products); short ones a loop of batched 4x4 matrix products (fewer
    operations when there are many points and few samples).
    """
    E = np.asarray(E, dtype=np.float64)
    n = E.shape[-2]
    batch = E.shape[:-2]
    if q0 is None:
        q0 = np.zeros(batch + (4,))
        q0[..., 0] = 1.0
    q0 = np.broadcast_to(np.asarray(q0, dtype=np.float64), batch + (4,))
    if n > 64:
        out = np.array(E, copy=True)
        off = 1
        while off < n:
            tail = hamilton(out[..., :-off, :], out[..., off:, :])
            out = np.concatenate([out[..., :off, :], tail], axis=-2)
            off *= 2
        return np.concatenate([q0[..., None, :], hamilton(q0[..., None, :], out)], axis=-2)
    R = _right_matrix(E)
    out = np.empty(batch + (n + 1, 4))
    out[..., 0, :] = q0
    cur = q0[..., :, None]
    for k in range(n):
        cur = R[..., k, :, :] @ cur
        out[..., k + 1, :] = cur[..., 0]
    return out


def _step(dt: float | ArrayLike, n: int) -> float | Array:
    """``dt`` as a float (one interval for every sample) or as (n, 1) per-sample intervals."""
    if np.ndim(dt) == 0:
        return float(dt)  # type: ignore[arg-type]
    d = np.asarray(dt, dtype=np.float64).reshape(-1)
    if d.shape[0] != n:
        raise ValueError(f"dt has {d.shape[0]} intervals for {n} samples")
    return d[:, None]


def _elapsed(step: float | Array, n: int) -> Array:
    """Times of the samples from the start, (n + 1,): ``k dt`` or the running sum."""
    if isinstance(step, float):
        return np.arange(n + 1) * step
    return np.concatenate([[0.0], np.cumsum(step[:, 0])])


def attitudes(q: ArrayLike, gyro: ArrayLike, dt: float | ArrayLike,
              earth_rate: ArrayLike | None = None) -> Array:
    """The attitudes of :func:`mechanise` alone: ``q`` (4,) through ``gyro`` (n, 3),
    returned at every sample, (n + 1, 4); a batch ``q`` (..., 4) with ``gyro`` (..., n, 3)
    gives (..., n + 1, 4).  ``dt``: one interval or (n,) per-sample intervals."""
    gyro = np.asarray(gyro, dtype=np.float64)
    n = gyro.shape[-2]
    step = _step(dt, n)
    Q = prefix_products(_qexp(gyro * step), np.asarray(q, dtype=np.float64))
    if earth_rate is not None and np.any(earth_rate):
        nav = qexp(-_elapsed(step, n)[:, None] * np.asarray(earth_rate, dtype=np.float64))
        Q = hamilton(nav, Q)
    return Q / np.linalg.norm(Q, axis=-1, keepdims=True)


def mechanise(p: ArrayLike, v: ArrayLike, q: ArrayLike, gyro: ArrayLike, accel: ArrayLike,
              dt: float | ArrayLike, gravity: ArrayLike,
              earth_rate: ArrayLike | None = None, *, all_samples: bool = False
              ) -> tuple[Array, Array, Array]:
    r"""Carry states through ``n`` IMU samples (module docstring for the scheme).

    Parameters
    ----------
    p, v : (m, 3) arrays; q : (m, 4) array
        Start position, velocity and attitude ``q_nb`` of ``m`` points.
    gyro, accel : (n, 3) or (m, n, 3) arrays
        Bias-corrected body angular rate (rad/s) and specific force (m/s²) per sample,
        shared by every point or one series per point.
    dt : float or (n,) array
        Sample interval (s), one for every sample or one per sample (a log's time stamps:
        the model holds each reading over its own interval).
    gravity : (3,) array
        :math:`g^n` (e.g. :func:`gravity_enu`).
    earth_rate : (3,) array or None
        :math:`\omega_{ie}^n`; ``None`` or zeros: no Earth rotation.
    all_samples : bool
        Return every sample ``(m, n + 1, ·)`` (index 0 is the start) instead of the end.

    Returns
    -------
    p, v, q : end states ``(m, 3), (m, 3), (m, 4)`` or, with ``all_samples``,
    ``(m, n + 1, 3), (m, n + 1, 3), (m, n + 1, 4)``.
    """
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    v = np.atleast_2d(np.asarray(v, dtype=np.float64))
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    m = q.shape[0]
    gyro = np.asarray(gyro, dtype=np.float64)
    accel = np.asarray(accel, dtype=np.float64)
    n = gyro.shape[-2]
    g = np.asarray(gravity, dtype=np.float64)
    wie = None if earth_rate is None else np.asarray(earth_rate, dtype=np.float64)
    if wie is not None and not np.any(wie):
        wie = None

    step = _step(dt, n)  # a float, or (n, 1) per-sample intervals
    phi = np.broadcast_to(gyro * step, (m, n, 3))
    f = np.broadcast_to(accel, (m, n, 3))
    # attitudes at the start of every interval: Q_k = Exp(-w_ie t_k) q E_0 ... E_{k-1}
    Q = prefix_products(_qexp(phi), q)  # (m, n + 1, 4)
    if wie is not None:
        nav = qexp(-_elapsed(step, n)[:, None] * wie)  # (n + 1, 4)
        Q = hamilton(nav[None], Q)
    Q = Q / np.linalg.norm(Q, axis=-1, keepdims=True)
    g1, g2 = _apply_gammas(phi, f)
    C = dcm_unit(Q[:, :n])  # (m, n, 3, 3)
    dv_f = np.einsum("mnij,mnj->mni", C, g1) * step
    dp_f = np.einsum("mnij,mnj->mni", C, g2) * (step * step)

    if wie is None:
        dv = dv_f + g * step
        V = np.concatenate([v[:, None, :], v[:, None, :] + np.cumsum(dv, axis=1)], axis=1)
        dp = V[:, :n] * step + dp_f + 0.5 * g * step * step
    else:
        V = np.empty((m, n + 1, 3))
        V[:, 0] = v
        dp = np.empty((m, n, 3))
        steps = np.broadcast_to(step, (n, 1))
        for k in range(n):
            h = steps[k]
            a = g - 2.0 * _cross(wie, V[:, k])
            V[:, k + 1] = V[:, k] + dv_f[:, k] + a * h
            dp[:, k] = V[:, k] * h + dp_f[:, k] + 0.5 * a * h * h
    if all_samples:
        Pp = np.concatenate([p[:, None, :], p[:, None, :] + np.cumsum(dp, axis=1)], axis=1)
        return Pp, V, Q
    return p + dp.sum(axis=1), V[:, -1], Q[:, -1]


def ideal_imu(v: ArrayLike, q: ArrayLike, dt: float, gravity: ArrayLike,
              earth_rate: ArrayLike | None = None) -> tuple[Array, Array]:
    r"""IMU readings that make :func:`mechanise` reproduce sampled velocities and attitudes.

    From ``v`` (K + 1, 3) and ``q`` (K + 1, 4) at the sample times:

    .. math::

        \omega_k = \mathrm{Log}\big(q_k^* \otimes \mathrm{Exp}(\omega_{ie}^n\Delta t)
                   \otimes q_{k+1}\big) / \Delta t, \qquad
        f_k = \Gamma_1(\omega_k \Delta t)^{-1}\, C(q_k)^\top
              \Big(\frac{v_{k+1} - v_k}{\Delta t} - g^n + 2\,\omega_{ie}^n \times v_k\Big).

    Mechanising these readings from ``(p_0, v_0, q_0)`` gives back ``q_k`` and ``v_k`` to
    round-off, and a position that follows the trapezoidal integral of ``v``.

    Returns
    -------
    gyro, accel : (K, 3) arrays (rad/s, m/s²).
    """
    v = np.asarray(v, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    g = np.asarray(gravity, dtype=np.float64)
    q_next = q[1:]
    if earth_rate is not None and np.any(earth_rate):
        wie = np.asarray(earth_rate, dtype=np.float64)
        q_next = qmul(qexp(wie * dt), q_next)
        coriolis = 2.0 * np.cross(wie, v[:-1])
    else:
        coriolis = 0.0
    gyro = qlog(qmul(qconj(q[:-1]), q_next)) / dt
    a_n = (v[1:] - v[:-1]) / dt - g + coriolis
    a_b = qrotate(qconj(q[:-1]), a_n)
    G1, _ = gamma_matrices(gyro * dt)
    accel = np.linalg.solve(G1, a_b[..., None])[..., 0]
    return gyro, accel
