r"""Preintegration of several epochs at once: :func:`nav.ins.preintegrate` over a stack.

An INS filter predicts one epoch (the IMU samples between two fixes) at a time, and
:func:`~nav.ins.preintegrate` pays numpy's fixed cost per call some thirty times per
epoch on arrays of about a hundred samples.  :func:`preintegrate_stack` computes the same
quantities for ``E`` epochs in the same number of calls, each epoch about its own biases:
the epochs' samples padded to a common count with zero-length samples, which change
nothing (:math:`\mathrm{Exp}(0) = I`, every sum weighted by :math:`\Delta t_k = 0`).  Each
result equals :func:`~nav.ins.preintegrate` of that epoch to round-off (a test: 1e-12).

A filter can only preintegrate ahead about biases it does not know yet; it takes the
biases of the mean at the start of a batch of epochs as the reference of all of them
(:class:`~nav.ins.Preintegrated` carries its reference ``b``, and
:func:`~nav.ins.propagate_preintegrated` moves every point, the mean included, to first
order in its bias offset from it).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from nav.ins import Preintegrated, _quaternion
from nav.quaternion import skew
from nav.strapdown import gamma_coefficients

Array = NDArray[np.float64]

__all__ = ["pad_epochs", "preintegrate_stack"]


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
    r""":func:`nav.ins.preintegrate` of ``E`` epochs: ``gyro, accel`` (E, n, 3), ``dt``
    (E, n) (padding: zero intervals at the end), biases ``b`` (E, 6); ``counts`` (E,) the
    true sample counts (the attitudes ``R_samples`` are cut to ``count + 1``).  The same
    formulas as :func:`~nav.ins.preintegrate`, each product over the samples batched over
    the epochs."""
    E, n = dt.shape
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
    bb = np.asarray(b, dtype=float)
    return [Preintegrated(_quaternion(R[e, -1]), dv[e], dp[e], J[e], bb[e].copy(),
                          float(tau[e]), R[e, :int(counts[e]) + 1]) for e in range(E)]
