r"""A chain of epochs (no global variables) solved and its marginals computed by square-root
cyclic reduction: every level is a handful of batched NumPy calls, not a Python loop over
the epochs.

The rows of a whitened linear least-squares problem :math:`\|A\,δ - b\|^2` (from
:func:`slam.chain_marginals.linear_rows`) each touch epoch ``base`` and ``base + 1``.  The
rows of each epoch form one square-root factor :math:`F_j = [U_j\ V_j\ r_j]` on
:math:`(x_j, x_{j+1})` (the last epoch's :math:`V = 0`; the coarser chains' factors have
:math:`2n` rows).  One level eliminates every odd epoch :math:`j` from the two
factors that hold it, by one QR with :math:`x_j`'s columns first:

.. math::

    \begin{bmatrix} V_{j-1} & U_{j-1} & 0 & r_{j-1} \\ U_j & 0 & V_j & r_j \end{bmatrix}
    \xrightarrow{Q^\top}
    \begin{bmatrix} R_j & S_j & T_j & d_j \\ 0 & U' & V' & r' \end{bmatrix}

(columns :math:`x_j, x_{j-1}, x_{j+1}`, rhs): the conditional
:math:`R_j x_j + S_j x_{j-1} + T_j x_{j+1} = d_j` and the factor :math:`[U'\ V'\ r']` on
:math:`(x_{j-1}, x_{j+1})`, consecutive epochs of the chain of the even epochs, which is
reduced the same way until one epoch is left.  Back-substitution walks the levels down:
:math:`x_j = R_j^{-1}(d_j - S_j x_{j-1} - T_j x_{j+1})`, and with :math:`K_j =
R_j^{-1}[S_j\ T_j]` and :math:`P` the joint covariance of :math:`(x_{j-1}, x_{j+1})`,

.. math::

    \Sigma_j = R_j^{-1} R_j^{-\top} + K_j P K_j^\top,\qquad
    \mathrm{Cov}(x_j, [x_{j-1}, x_{j+1}]) = -K_j P,

which also gives the covariances of the consecutive pairs the next level down needs.
Only orthogonal transformations touch :math:`A`, as in the sequential sweep of
:func:`slam.chain_marginals.chain_marginals` (its reference).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class _Level:
    """One level's conditionals of its odd epochs: ``R_inv`` (k, n, n), ``K`` (k, n, 2n)
    (:math:`R^{-1}[S\\ T]`), ``d`` (k, n) (:math:`R^{-1} d`), over a chain of ``size``."""

    R_inv: Array
    K: Array
    d: Array
    size: int


def _qr_r(a: Array) -> Array:
    """The ``R`` factors of a stack (k, m, c), padded with zero rows to (k, max(m, c), c)."""
    r = np.linalg.qr(a, mode="r")
    if r.shape[-2] < a.shape[-1]:
        r = np.concatenate([r, np.zeros(r.shape[:-2] + (a.shape[-1] - r.shape[-2],
                                                         a.shape[-1]))], axis=-2)
    return r


def _inv_upper(R: Array, what: str) -> Array:
    diag = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    if np.any(~(diag > 0.0)):
        raise np.linalg.LinAlgError(f"{what}: the chain is indeterminate")
    return np.linalg.inv(R)


def epoch_factors(local: Array, rhs: Array, base: Array, M: int) -> Array:
    """(M, p, 2n + 1): each epoch's rows ``[local | rhs]`` as one factor, padded with zero
    rows (they change no QR) to the most any epoch has; an epoch with more than 2n rows
    (the first, with the priors) compressed by QR to 2n, so ``p <= max(2n, rows)``."""
    n2 = local.shape[1]
    order = np.argsort(base, kind="stable")
    b = base[order]
    counts = np.bincount(b, minlength=M)
    if len(counts) > M:
        raise ValueError(f"a row's epoch is past the last ({M - 1})")
    start = np.cumsum(counts) - counts
    slot = np.arange(len(b)) - start[b]
    full = counts > n2
    p = max(int(counts[~full].max(initial=0)), n2 if full.any() else 1)
    dense = np.zeros((M, p, n2 + 1))
    fit = ~full[b]
    dense[b[fit], slot[fit], :n2] = local[order[fit]]
    dense[b[fit], slot[fit], n2] = rhs[order[fit]]
    if full.any():
        big = np.flatnonzero(full)
        extra = np.zeros((len(big), int(counts[big].max()), n2 + 1))
        at = np.searchsorted(big, b[~fit])
        extra[at, slot[~fit], :n2] = local[order[~fit]]
        extra[at, slot[~fit], n2] = rhs[order[~fit]]
        dense[big] = _with_rows(extra, p)
    return dense


def _with_rows(F: Array, r: int) -> Array:
    """Factors (k, p, c) as (k, r, c): compressed by QR (residual rows dropped) or padded
    with zero rows."""
    if F.shape[1] > r:
        return _qr_r(F)[:, :r]
    if F.shape[1] < r:
        return np.concatenate([F, np.zeros((len(F), r - F.shape[1], F.shape[2]))], axis=1)
    return F


def reduce_chain(F: Array) -> tuple[list[_Level], Array, Array]:
    """The levels of the reduction of the chain factors ``F`` (M, p, 2n + 1) and the last
    epoch's ``R^{-1}`` (n, n) and ``R^{-1} d`` (n,); the factors of the coarser chains
    have 2n rows."""
    n = F.shape[2] // 2
    levels = []
    while len(F) > 1:
        L, p = len(F), F.shape[1]
        prev, cur = F[0:L - 1:2], F[1:L:2]  # the two factors of each odd epoch
        k = len(cur)
        st = np.zeros((k, 2 * p, 3 * n + 1))
        st[:, :p, :n], st[:, :p, n:2 * n] = prev[:, :, n:2 * n], prev[:, :, :n]
        st[:, :p, 3 * n] = prev[:, :, 2 * n]
        st[:, p:, :n], st[:, p:, 2 * n:3 * n] = cur[:, :, :n], cur[:, :, n:2 * n]
        st[:, p:, 3 * n] = cur[:, :, 2 * n]
        R = _qr_r(st)
        R_inv = _inv_upper(R[:, :n, :n], "an epoch")
        K = R_inv @ R[:, :n, n:3 * n]
        d = np.einsum("kij,kj->ki", R_inv, R[:, :n, 3 * n])
        levels.append(_Level(R_inv, K, d, L))
        coarse = R[:, n:3 * n, n:]
        F = np.concatenate([coarse, _with_rows(F[L - 1:L], 2 * n)]) if L % 2 else coarse
    last = _qr_r(F[0][None, :, np.r_[0:n, 2 * n]])[0]
    R_inv = _inv_upper(last[:n, :n], "the last epoch")
    return levels, R_inv, R_inv @ last[:n, n]


def _fine_index(L: int) -> tuple[Array, Array]:
    """The even (kept) and odd (eliminated) epochs of a chain of ``L``."""
    return np.arange(0, L, 2), np.arange(1, L, 2)


def chain_solve(levels: list[_Level], R_inv: Array, d: Array) -> Array:
    """(M, n) the least-squares solution by back-substitution down the levels."""
    x = d[None]
    for lv in reversed(levels):
        even, odd = _fine_index(lv.size)
        n = x.shape[1]
        nxt = np.zeros((len(odd), n))
        has_next = odd + 1 < lv.size
        nxt[has_next] = x[(odd[has_next] + 1) // 2]
        pair = np.concatenate([x[(odd - 1) // 2], nxt], axis=1)
        fine = np.empty((lv.size, n))
        fine[even], fine[odd] = x, lv.d - np.einsum("kij,kj->ki", lv.K, pair)
        x = fine
    return x


def chain_covariances(levels: list[_Level], R_inv: Array) -> Array:
    r"""(M, n, n) every epoch's marginal covariance, down the levels (module docstring);
    each level also carries the covariances :math:`C_i = \mathrm{Cov}(x_i, x_{i+1})`."""
    n = R_inv.shape[0]
    sig = (R_inv @ R_inv.T)[None]
    cross = np.zeros((0, n, n))
    for lv in reversed(levels):
        even, odd = _fine_index(lv.size)
        k = len(odd)
        has_next = odd + 1 < lv.size
        p, q = (odd - 1) // 2, np.minimum((odd + 1) // 2, len(sig) - 1)
        P = np.zeros((k, 2 * n, 2 * n))
        P[:, :n, :n] = sig[p]
        P[has_next, n:, n:] = sig[q[has_next]]
        P[has_next, :n, n:] = cross[p[has_next]]
        P[:, n:, :n] = np.swapaxes(P[:, :n, n:], -1, -2)
        KP = lv.K @ P
        s_odd = lv.R_inv @ np.swapaxes(lv.R_inv, -1, -2) + KP @ np.swapaxes(lv.K, -1, -2)
        fine_sig = np.empty((lv.size, n, n))
        fine_sig[even], fine_sig[odd] = sig, 0.5 * (s_odd + np.swapaxes(s_odd, -1, -2))
        fine_cross = np.empty((lv.size - 1, n, n))  # Cov(x_i, x_{i+1})
        fine_cross[odd - 1] = np.swapaxes(-KP[:, :, :n], -1, -2)  # Cov(x_{j-1}, x_j)
        fine_cross[odd[has_next]] = -KP[has_next, :, n:]  # Cov(x_j, x_{j+1})
        sig, cross = fine_sig, fine_cross
    return sig

