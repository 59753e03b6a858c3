r"""Simulated satellite attitude: truth, a strapdown gyro and a star sensor
([Wang SRCKF-SLAM] §5.1).

Motion (navigation frame ``n`` inertial, equal to the orbit frame ``o`` at t = 0)
---------------------------------------------------------------------------------
The satellite turns at a constant body rate :math:`\omega_{ob}` relative to the orbit
(LVLH) frame, and the orbit frame turns about its :math:`-y` axis (the negative orbit
normal) at the orbital rate :math:`\omega_0`.  Both are rotations at a constant rate about
a fixed axis, so the truth is in closed form (no integration error at all):

.. math::

    q_{nb}(t) = \mathrm{Exp}(\omega_{io} t) \otimes q_{nb}(0) \otimes \mathrm{Exp}(\omega_{ob} t),
    \qquad \omega_{io} = [0, -\omega_0, 0],

and the inertial body rate the gyro senses, :math:`\omega_{ib}^b(t) = \omega_{ob} +
C(q_{ob})^\top \omega_{io}`, varies slowly (by :math:`\omega_0 = 0.001` rad/s in direction
over the run) - the "small variation" of the body rate.

Gyro (rate ``1/dt``)
--------------------
Sample ``k`` covers :math:`[t_k, t_{k+1}]` and is an integrating gyro's output: the exact
attitude increment divided by ``dt``, plus the bias and angle random walk,

.. math::

    \tilde\omega_k = \mathrm{Log}(q_k^* \otimes q_{k+1}) / dt + b_k + n_k,
    \qquad n_k \sim N(0, \sigma_{arw}^2 / dt\, I),\quad
    b_{k+1} = b_k + \sigma_{rw}\sqrt{dt}\, m_k,

with :math:`b_0` the constant drift.  So ``qpropagate(q_k, ω̃_k - b_k, dt) = q_{k+1}``
to round-off when the noises are zero: a filter given the true bias reproduces the truth.

Star sensor (every ``samples_per_star`` gyro samples, first at t = 0)
---------------------------------------------------------------------
* quaternion mode: :math:`\tilde q = q \otimes \mathrm{Exp}(v)`, :math:`v \sim N(0,
  \sigma^2 I_3)` (body-frame, right perturbation);
* vector mode: :math:`\tilde b_j = \mathrm{normalise}(C(q)^\top r_j + v_\perp)` for fixed
  nav-frame reference stars :math:`r_j`, with :math:`v_\perp` the projection of
  :math:`N(0, \sigma^2 I_3)` onto the plane normal to :math:`C(q)^\top r_j` (σ per
  tangent axis).  The stars are always in view (no field-of-view model).

All randomness comes from the ``numpy.random.Generator`` passed in; draws happen in a
fixed order (angle random walk, rate random walk, star noise) whatever the noise levels.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.arrays import read_only
from nav.euler import euler_zxy_to_q
from nav.quaternion import qconj, qexp, qlog, qmul, qnormalize, qrotate

Array = NDArray[np.float64]

STAR_MODES = ("quaternion", "vectors")

__all__ = ["AttitudeLog", "AttitudeSimConfig", "simulate_attitude", "truth_attitude"]


@dataclass(frozen=True)
class AttitudeSimConfig:
    """What the simulation needs, in SI units (radians, seconds).

    initial_euler_rad : ``[roll, pitch, yaw]``, [Wang SRCKF-SLAM]'s Z-X-Y sequence.
    body_rate_rad_s : body rate relative to the orbit frame (constant).
    gyro_bias_rad_s : b(0), per axis.
    """

    duration_s: float
    gyro_rate_hz: float
    star_rate_hz: float
    orbital_rate_rad_s: float
    initial_euler_rad: tuple[float, float, float]
    body_rate_rad_s: tuple[float, float, float]
    gyro_bias_rad_s: tuple[float, float, float]
    gyro_bias_rw_rad_s_sqrt_s: float
    gyro_arw_rad_sqrt_s: float
    star_sigma_rad: float
    star_mode: str = "quaternion"
    star_directions: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0),
                                                               (0.0, 1.0, 0.0))

    def __post_init__(self) -> None:
        if self.star_mode not in STAR_MODES:
            raise ValueError(f"star_mode must be one of {STAR_MODES}, got {self.star_mode!r}")
        ratio = self.gyro_rate_hz / self.star_rate_hz
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            raise ValueError("the star rate must divide the gyro rate a whole number of times")

    @property
    def dt_s(self) -> float:
        return 1.0 / self.gyro_rate_hz

    @property
    def samples_per_star(self) -> int:
        return int(round(self.gyro_rate_hz / self.star_rate_hz))

    @property
    def n_star(self) -> int:
        """Star epochs (t = 0 included)."""
        return int(round(self.duration_s * self.star_rate_hz)) + 1

    @property
    def n_gyro(self) -> int:
        """Gyro samples, ``samples_per_star`` per star interval."""
        return (self.n_star - 1) * self.samples_per_star


@dataclass(frozen=True, eq=False)
class AttitudeLog:
    """One simulated run (arrays read-only).

    times : (N + 1,) gyro epochs ``t_k = k·dt``; gyro sample ``k`` covers
        ``[t_k, t_{k+1}]``.
    gyro : (N, 3) measured body rate (rad/s), bias and noise included.
    truth_q : (N + 1, 4) ``q_nb`` at the gyro epochs; truth_bias : (N + 1, 3) rad/s,
        ``truth_bias[k]`` is the bias during sample ``k``.
    star_index : (M,) gyro epoch of each star epoch (``j·samples_per_star``);
        star_times : (M,).
    star_q : (M, 4) measured ``q_nb`` (quaternion mode) else None.
    star_vectors : (M, k, 3) measured body-frame unit vectors (vector mode) else None.
    star_refs : (k, 3) nav-frame reference directions (vector mode; empty otherwise).
    metadata : the configuration and the noise levels actually used.
    """

    dt: float
    samples_per_star: int
    times: Array
    gyro: Array
    truth_q: Array
    truth_bias: Array
    star_index: NDArray[np.int64]
    star_times: Array
    star_q: Array | None
    star_vectors: Array | None
    star_refs: Array
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def n_star(self) -> int:
        return len(self.star_index)

    @property
    def star_truth_q(self) -> Array:
        """(M, 4) true attitude at the star epochs."""
        return self.truth_q[self.star_index]

    @property
    def star_truth_bias(self) -> Array:
        """(M, 3) true bias at the star epochs."""
        return self.truth_bias[self.star_index]

    def gyro_block(self, j: int) -> Array:
        """(samples_per_star, 3) gyro samples from star epoch ``j`` to ``j + 1``."""
        s = self.samples_per_star
        return self.gyro[j * s:(j + 1) * s]


def truth_attitude(cfg: AttitudeSimConfig, t: Array) -> Array:
    """``q_nb(t)`` (len(t), 4) of the closed-form motion in the module docstring."""
    t = np.asarray(t, dtype=np.float64)
    q0 = euler_zxy_to_q(*cfg.initial_euler_rad)
    w_io = np.array([0.0, -cfg.orbital_rate_rad_s, 0.0])
    w_ob = np.asarray(cfg.body_rate_rad_s, dtype=np.float64)
    q = qmul(qmul(qexp(t[:, None] * w_io), q0), qexp(t[:, None] * w_ob))
    return qnormalize(q)


def simulate_attitude(cfg: AttitudeSimConfig, rng: np.random.Generator) -> AttitudeLog:
    """Simulate one run of truth, gyro and star sensor (see the module docstring)."""
    dt, s = cfg.dt_s, cfg.samples_per_star
    N, M = cfg.n_gyro, cfg.n_star
    times = np.arange(N + 1) * dt
    q = truth_attitude(cfg, times)
    increment = qlog(qmul(qconj(q[:-1]), q[1:])) / dt  # exact mean rate over each sample

    arw = rng.standard_normal((N, 3))
    rw = rng.standard_normal((N, 3))
    bias = np.empty((N + 1, 3))
    bias[0] = cfg.gyro_bias_rad_s
    bias[1:] = cfg.gyro_bias_rw_rad_s_sqrt_s * np.sqrt(dt) * rw
    bias = np.cumsum(bias, axis=0)
    gyro = increment + bias[:-1] + (cfg.gyro_arw_rad_sqrt_s / np.sqrt(dt)) * arw

    star_index = np.arange(M, dtype=np.int64) * s
    q_star = q[star_index]
    refs = np.array(cfg.star_directions, dtype=np.float64).reshape(-1, 3)
    refs = refs / np.linalg.norm(refs, axis=1, keepdims=True)
    star_q = star_vec = None
    if cfg.star_mode == "quaternion":
        v = cfg.star_sigma_rad * rng.standard_normal((M, 3))
        star_q = qnormalize(qmul(q_star, qexp(v)))
    else:
        b = qrotate(qconj(q_star)[:, None, :], refs[None, :, :])  # (M, k, 3)
        v = cfg.star_sigma_rad * rng.standard_normal(b.shape)
        v_perp = v - np.sum(v * b, axis=-1, keepdims=True) * b
        noisy = b + v_perp
        star_vec = noisy / np.linalg.norm(noisy, axis=-1, keepdims=True)

    meta = {
        "star_mode": cfg.star_mode,
        "gyro_rate_hz": cfg.gyro_rate_hz,
        "star_rate_hz": cfg.star_rate_hz,
        "duration_s": cfg.duration_s,
        "gyro_arw_rad_sqrt_s": cfg.gyro_arw_rad_sqrt_s,
        "gyro_bias_rw_rad_s_sqrt_s": cfg.gyro_bias_rw_rad_s_sqrt_s,
        "star_sigma_rad": cfg.star_sigma_rad,
        "orbital_rate_rad_s": cfg.orbital_rate_rad_s,
    }
    return AttitudeLog(
        dt=dt,
        samples_per_star=s,
        times=read_only(times, np.float64),
        gyro=read_only(gyro, np.float64),
        truth_q=read_only(q, np.float64),
        truth_bias=read_only(bias, np.float64),
        star_index=read_only(star_index, np.int64),
        star_times=read_only(times[star_index], np.float64),
        star_q=None if star_q is None else read_only(star_q, np.float64),
        star_vectors=None if star_vec is None else read_only(star_vec, np.float64),
        star_refs=read_only(refs if cfg.star_mode == "vectors" else np.zeros((0, 3)), np.float64),
        metadata=meta,
    )
