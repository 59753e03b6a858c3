r"""Planar SLAM models: Bailey's car-like vehicle and a range-bearing sensor.

The joint state is :math:`s = [x, y, φ, m_{1x}, m_{1y}, \dots, m_{Nx}, m_{Ny}]` on the
space ``Wrapped(3 + 2N, (2,))`` (only the heading is an angle).  All functions take
points as rows and are vectorised over them.

Motion (control :math:`u = [V, G]`, noise :math:`w` added to the control):

.. math::

    x' = x + V dt \cos(G + φ),\quad y' = y + V dt \sin(G + φ),\quad
    φ' = \mathrm{wrap}(φ + V dt \sin G / WB).

Observation of landmark :math:`m`:

.. math::

    z = \big[\ \|m - p\|,\ \mathrm{wrap}(\operatorname{atan2}(m_y - y, m_x - x) - φ)\ \big].

Inverse observation (augmentation): :math:`m = p + r[\cos(φ + b), \sin(φ + b)]`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from estimators import Measurement, Noise, Transition, Wrapped, wrap_angle
from estimators.linalg import Array


def state_space(n_landmarks: int) -> Wrapped:
    """The joint state's space: heading wrapped, everything else Euclidean."""
    return Wrapped(3 + 2 * n_landmarks, (2,))


def observation_space(k: int) -> Wrapped:
    """Space of ``k`` stacked ``[range, bearing]`` observations."""
    return Wrapped(2 * k, tuple(range(1, 2 * k, 2)))


def motion_model(dt: float, wheelbase: float, control_cov: Array, n_steps: int = 1
                 ) -> Transition:
    r"""Joint-state transition over ``n_steps`` control steps; landmarks stay (declared:
    ``moves = 3``, the pose; the observation model declares the rows it ``reads``).

    ``u`` is the (n_steps, 2) block of noisy controls; the noise ``W`` (m, 2·n_steps)
    holds an independent control error per step, so sigma-point filters propagate
    points through the exact compounded car model (no re-Gaussianisation between
    steps).  The EKF's Jacobians chain the per-step ones along the mean path, which
    is identical to predicting step by step:

    .. math::  F = F_{s} \cdots F_1,\qquad G = [F_s \cdots F_2 G_1,\ \dots,\ G_s].
    """

    def f(X: Array, u: Array, W: Array) -> Array:
        # Per-step controls as (n_steps, m) rows, then the motion equations above step by step
        # (leading axes: a batch of runs, each with its own controls u (..., n_steps, 2)).
        V = u[..., :, :1] + np.swapaxes(W[..., 0::2], -1, -2)
        G = u[..., :, 1:] + np.swapaxes(W[..., 1::2], -1, -2)
        vdt = V * dt
        turn = vdt * np.sin(G) / wheelbase
        Y = X.copy()
        x, y, heading = Y[..., 0], Y[..., 1], X[..., 2]
        for i in range(n_steps):  # the heading wrapped once at the end: cos/sin need not
            a = G[..., i, :] + heading
            x += vdt[..., i, :] * np.cos(a)
            y += vdt[..., i, :] * np.sin(a)
            heading = heading + turn[..., i, :]
        Y[..., 2] = wrap_angle(heading)
        return Y

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        if x.ndim > 1:
            return _motion_jacobian_batch(x, u, dt, wheelbase)
        n = x.shape[0]
        V, Gs = u[:, 0], u[:, 1]
        vdt = V * dt
        turn = vdt * np.sin(Gs) / wheelbase
        heading = np.empty(n_steps)  # along the mean path, as f steps it
        h, turns = float(x[2]), turn.tolist()
        for i in range(n_steps):
            heading[i] = h
            h = wrap_angle(h + turns[i])
        a = Gs + heading
        sa, ca = np.sin(a), np.cos(a)
        F = np.zeros((n_steps, 3, 3))
        F[:, [0, 1, 2], [0, 1, 2]] = 1.0
        F[:, 0, 2] = -V * dt * sa
        F[:, 1, 2] = V * dt * ca
        Gi = np.empty((n_steps, 3, 2))
        Gi[:, 0, 0], Gi[:, 0, 1] = dt * ca, -V * dt * sa
        Gi[:, 1, 0], Gi[:, 1, 1] = dt * sa, V * dt * ca
        Gi[:, 2, 0], Gi[:, 2, 1] = dt * np.sin(Gs) / wheelbase, V * dt * np.cos(Gs) / wheelbase
        Fv = np.eye(3)
        Gv = np.zeros((3, 2 * n_steps))
        for i in range(n_steps):
            Fv = F[i] @ Fv
            Gv = F[i] @ Gv
            Gv[:, 2 * i:2 * i + 2] = Gi[i]
        Fm = np.eye(n)
        Fm[:3, :3] = Fv
        Gm = np.zeros((n, 2 * n_steps))
        Gm[:3] = Gv
        return Fm, Gm

    cov = np.kron(np.eye(n_steps), control_cov)
    return Transition(f, Noise.from_cov(cov), additive=False, jacobian=jacobian, moves=3)


def _motion_jacobian_batch(x: Array, u: Array, dt: float, wheelbase: float
                           ) -> tuple[Array, Array]:
    r"""The motion Jacobians ``(F, G)`` (..., n, n), (..., n, 2 n_steps) of a batch of states
    ``x`` (..., n) with controls ``u`` (..., n_steps, 2): :func:`motion_model`'s chain of
    per-step Jacobians in closed form, for every member at once.  Each step's state
    Jacobian is a shear :math:`F_i = I + c_i e_φ^\top` (:math:`c_i = V dt(-\sin a_i,
    \cos a_i, 0)`, :math:`e_φ^\top c_j = 0`), so :math:`F_j \cdots F_{i+1} = I +
    (\sum_{i < l \le j} c_l) e_φ^\top` and :math:`F = I + (\sum_i c_i) e_φ^\top`,
    :math:`G_{[i]} = G_i + (\sum_{l > i} c_l) (G_i)_{φ,:}` (the headings along the mean
    path are the running sum of the turns; their wrapping changes no sine or cosine)."""
    lead, n = x.shape[:-1], x.shape[-1]
    s = u.shape[-2]
    V, Gs = u[..., 0], u[..., 1]
    vdt = V * dt
    turn = vdt * np.sin(Gs) / wheelbase
    heading = x[..., 2:3] + np.concatenate(
        [np.zeros(lead + (1,)), np.cumsum(turn[..., :-1], axis=-1)], axis=-1)
    a = Gs + heading
    sa, ca = np.sin(a), np.cos(a)
    c = np.stack([-vdt * sa, vdt * ca], axis=-2)                 # (..., 2, s): c_i, x and y
    after = np.cumsum(c[..., ::-1], axis=-1)[..., ::-1] - c      # sum over l > i of c_l
    Gi = np.empty(lead + (3, 2, s))
    Gi[..., 0, 0, :], Gi[..., 0, 1, :] = dt * ca, -V * dt * sa
    Gi[..., 1, 0, :], Gi[..., 1, 1, :] = dt * sa, V * dt * ca
    Gi[..., 2, 0, :] = dt * np.sin(Gs) / wheelbase
    Gi[..., 2, 1, :] = V * dt * np.cos(Gs) / wheelbase
    Gi[..., :2, :, :] += after[..., :, None, :] * Gi[..., 2:3, :, :]
    Fm = np.zeros(lead + (n, n))
    i = np.arange(n)
    Fm[..., i, i] = 1.0
    Fm[..., :2, 2] = after[..., 0] + c[..., 0]
    Gm = np.zeros(lead + (n, 2 * s))
    Gm[..., :3, :] = np.swapaxes(Gi, -1, -2).reshape(lead + (3, 2 * s))
    return Fm, Gm


def range_bearing(X: Array, slots: Array) -> Array:
    """Stacked ``[r, b]`` of the landmarks at state slots ``slots`` (k,) from poses X
    (..., m, n) (leading axes: a batch)."""
    cols = 3 + 2 * np.asarray(slots)
    dx = X[..., cols] - X[..., :1]
    dy = X[..., cols + 1] - X[..., 1:2]
    Z = np.empty(X.shape[:-1] + (2 * len(cols),))
    Z[..., 0::2] = np.hypot(dx, dy)
    Z[..., 1::2] = wrap_angle(np.arctan2(dy, dx) - X[..., 2:3])
    return Z


def range_bearing_jacobian(x: Array, slots: Array) -> Array:
    """Analytic Jacobian (2k, n) of :func:`range_bearing` at one state ``x`` (a batch
    (..., n) gives (..., 2k, n))."""
    if x.ndim > 1:
        return _range_bearing_jacobian_batch(x, np.asarray(slots, dtype=int))
    n = x.shape[0]
    H = np.zeros((2 * len(slots), n))
    for i, s in enumerate(slots):
        c = 3 + 2 * int(s)
        dx, dy = x[c] - x[0], x[c + 1] - x[1]
        q = dx * dx + dy * dy
        r = np.sqrt(q)
        H[2 * i, [0, 1, c, c + 1]] = [-dx / r, -dy / r, dx / r, dy / r]
        H[2 * i + 1, [0, 1, 2, c, c + 1]] = [dy / q, -dx / q, -1.0, -dy / q, dx / q]
    return H


def _range_bearing_jacobian_batch(x: Array, slots: Array) -> Array:
    lead, n, k = x.shape[:-1], x.shape[-1], len(slots)
    c = 3 + 2 * slots
    dx, dy = x[..., c] - x[..., :1], x[..., c + 1] - x[..., 1:2]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    H = np.zeros(lead + (k, 2, n))
    i = np.arange(k)
    H[..., i, 0, 0], H[..., i, 0, 1] = -dx / r, -dy / r
    H[..., i, 0, c], H[..., i, 0, c + 1] = dx / r, dy / r
    H[..., i, 1, 0], H[..., i, 1, 1], H[..., i, 1, 2] = dy / q, -dx / q, -1.0
    H[..., i, 1, c], H[..., i, 1, c + 1] = -dy / q, dx / q
    return H.reshape(lead + (2 * k, n))


def stacked_noise(k: int, obs_cov: Array) -> Noise:
    """The noise of ``k`` independent observations of covariance ``obs_cov`` (a value:
    built once per ``k`` and covariance, as every epoch with ``k`` sightings needs it)."""
    cov = np.asarray(obs_cov, dtype=float)
    return _stacked_noise(k, cov.shape[0], cov.tobytes())


@lru_cache(maxsize=256)
def _stacked_noise(k: int, d: int, cov: bytes) -> Noise:
    noise = Noise.from_cov(np.kron(np.eye(k), np.frombuffer(cov).reshape(d, d)))
    for a in (noise.cov, noise.sqrt):  # shared by every caller: read-only
        a.setflags(write=False)
    return noise


def observation_model(slots: Array, obs_cov: Array) -> Measurement:
    """Batch measurement of the landmarks in ``slots`` (one ``[r, b]`` pair each)."""
    slots = np.asarray(slots, dtype=int)
    k = len(slots)
    reads = (0, 1, 2, *(int(r) for s in slots for r in (3 + 2 * s, 4 + 2 * s)))
    return Measurement(lambda X: range_bearing(X, slots), stacked_noise(k, obs_cov),
                       space=observation_space(k),
                       jacobian=lambda x: range_bearing_jacobian(x, slots), reads=reads)


def landmark_from_observation(P: Array, Z: Array) -> Array:
    """Inverse observation: landmark positions (..., m, 2k) from poses (..., m, 3) and ``Z``
    (..., m, 2k)."""
    r, b = Z[..., 0::2], Z[..., 1::2]
    a = P[..., 2:3] + b
    out = np.empty(np.broadcast_shapes(P.shape[:-1], Z.shape[:-1]) + Z.shape[-1:])
    out[..., 0::2] = P[..., :1] + r * np.cos(a)
    out[..., 1::2] = P[..., 1:2] + r * np.sin(a)
    return out


def augmentation_model(n_landmarks: int, z_new: Array, obs_cov: Array) -> Transition:
    """Grow the state by the landmarks first seen in ``z_new`` (2k,).

    A transition into the bigger space, with the observation noise entering
    non-additively: :math:`s' = [s;\\ g(s_v, z + v)]`.  Sigma-point filters draw points
    over :math:`[s; v]`, so the new cross-covariances with the whole map come out of
    the same points; the EKF uses the analytic Jacobians.
    """
    k = z_new.shape[0] // 2
    n = 3 + 2 * n_landmarks

    def f(X: Array, u: Array, W: Array) -> Array:
        return np.concatenate([X, landmark_from_observation(X[..., :3], u[..., None, :] + W)],
                              axis=-1)

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        if x.ndim > 1:
            return _augmentation_jacobian_batch(x, u, n, k)
        F = np.zeros((n + 2 * k, n))
        F[:n] = np.eye(n)
        Gm = np.zeros((n + 2 * k, 2 * k))
        for i in range(k):
            r, b = u[2 * i], u[2 * i + 1]
            a = x[2] + b
            c, s = np.cos(a), np.sin(a)
            row = n + 2 * i
            F[row, [0, 2]] = [1.0, -r * s]
            F[row + 1, [1, 2]] = [1.0, r * c]
            Gm[row:row + 2, 2 * i:2 * i + 2] = [[c, -r * s], [s, r * c]]
        return F, Gm

    return Transition(f, stacked_noise(k, obs_cov), additive=False,
                      space=state_space(n_landmarks + k), jacobian=jacobian)


def _augmentation_jacobian_batch(x: Array, u: Array, n: int, k: int) -> tuple[Array, Array]:
    """:func:`augmentation_model`'s Jacobians for a batch of states (..., n) and
    observations (..., 2k)."""
    lead = x.shape[:-1]
    F = np.zeros(lead + (n + 2 * k, n))
    F[..., :n, :n] = np.eye(n)
    Gm = np.zeros(lead + (n + 2 * k, 2 * k))
    r, b = u[..., 0::2], u[..., 1::2]
    a = x[..., 2:3] + b
    c, s = np.cos(a), np.sin(a)
    rows = n + 2 * np.arange(k)
    F[..., rows, 0], F[..., rows, 2] = 1.0, -r * s
    F[..., rows + 1, 1], F[..., rows + 1, 2] = 1.0, r * c
    cols = 2 * np.arange(k)
    Gm[..., rows, cols], Gm[..., rows, cols + 1] = c, -r * s
    Gm[..., rows + 1, cols], Gm[..., rows + 1, cols + 1] = s, r * c
    return F, Gm
