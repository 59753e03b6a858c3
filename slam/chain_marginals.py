r"""Marginal covariances of a factor graph that is a chain of epochs plus a few global
variables (landmarks), by one square-root sweep: the smoothers' marginals computed once.

The graph is linearised at its optimum and its whitened Jacobian :math:`J` read with
``sparseJacobian_``.  Each epoch has ``n`` tangent columns (its variables in a fixed
order) and the global variables ``g`` columns; every row touches one epoch or two
consecutive ones, plus any global columns.  Ordering the epochs first and the globals
last, a forward QR sweep eliminates one epoch at a time: QR of the rows whose first epoch
is ``j`` under the factor carried from ``j - 1`` (columns ``[x_j, x_{j+1}, L]``) gives the
conditional of epoch ``j``, :math:`R_{jj} x_j + R_{j,j+1} x_{j+1} + R_{jL} L`, and the
factor carried to ``j + 1``; after the last epoch the carried factor is :math:`R_{LL}`.
Back-substituting, with :math:`P_j` the joint covariance of :math:`y_j = [x_j, L]`:

.. math::

    \Sigma_{LL} = R_{LL}^{-1} R_{LL}^{-\top},\quad
    K_j = R_{jj}^{-1} [R_{j,j+1}\ R_{jL}],\quad
    \Sigma_j = R_{jj}^{-1} R_{jj}^{-\top} + K_j P_{j+1} K_j^\top,\quad
    \mathrm{Cov}(x_j, L) = -K_j P_{j+1}[:, L]

(:math:`P_M` is :math:`\Sigma_{LL}` alone; the Rauch-Tung-Striebel form).  The sweep works
on :math:`J`, never :math:`J^\top J`, so it keeps the precision of a dense QR: on the
star-sensor chain it agrees with a ``longdouble`` inverse to 6e-12 of
:math:`\sqrt{\Sigma_{ii}\Sigma_{kk}}` where GTSAM's ``Marginals`` (the Bayes tree's
Cholesky) is off by 7e-9.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

Array = NDArray[np.float64]


def jacobian_rows(graph: Any, values: Any, slots: Mapping[int, tuple[int, int]], n: int,
                  g: int) -> tuple[Array, Array, Array]:
    """The whitened Jacobian of ``graph`` at ``values`` as row windows.

    ``slots[key] = (epoch, offset)``: the key's tangent columns start at ``offset`` in
    its epoch's ``n`` columns, or (``epoch = -1``) at ``offset`` in the ``g`` global
    columns.  Returns ``local`` (R, 2n) (each row's entries on epochs ``base`` and
    ``base + 1``), ``glob`` (R, g) and ``base`` (R,); ValueError if a row touches epochs
    further apart or no epoch.
    """
    return linear_rows(graph.linearize(values), values.dims(), slots, n, g)[:3]


def linear_rows(linear: Any, dims: Mapping[int, int], slots: Mapping[int, tuple[int, int]],
                n: int, g: int) -> tuple[Array, Array, Array, Array]:
    """:func:`jacobian_rows` of a linearised graph (``GaussianFactorGraph``; ``dims`` its
    keys' tangent dimensions), with the right-hand side ``b`` (R,) of its rows
    :math:`||A δ - b||^2` as a fourth array."""
    S = linear.sparseJacobian_()
    r, c, v = S[0].astype(np.int64) - 1, S[1].astype(np.int64) - 1, S[2]
    keys = sorted(dims)  # sparseJacobian_'s column order: sorted keys
    d = np.array([dims[k] for k in keys], dtype=np.int64)
    e_key, off_key = np.array([slots[k] for k in keys], dtype=np.int64).reshape(-1, 2).T
    within = np.arange(int(d.sum())) - np.repeat(np.cumsum(d) - d, d)
    ep, cl = np.repeat(e_key, d), np.repeat(off_key, d) + within
    keep = c < len(ep)  # the last column is the right-hand side
    n_rows = int(r.max()) + 1 if len(r) else 0
    rhs = np.zeros(n_rows)
    rhs[r[~keep]] = v[~keep]
    r, c, v = r[keep], c[keep], v[keep]
    on_epoch = ep[c] >= 0
    none = np.iinfo(np.int64).max
    base = np.full(n_rows, none)
    np.minimum.at(base, r[on_epoch], ep[c[on_epoch]])
    if np.any(base == none):
        raise ValueError("a factor touches no epoch")
    local, glob = np.zeros((n_rows, 2 * n)), np.zeros((n_rows, g))
    re, ce = r[on_epoch], c[on_epoch]
    offset = (ep[ce] - base[re]) * n + cl[ce]
    if np.any(offset >= 2 * n):
        raise ValueError("a factor couples epochs that are not consecutive")
    local[re, offset] = v[on_epoch]
    glob[r[~on_epoch], cl[c[~on_epoch]]] = v[~on_epoch]
    return local, glob, base, rhs


def _triangularise(A: Array, k: int) -> tuple[Array, Array]:
    """QR of the first ``k`` columns of ``A`` (m, k + w) (LAPACK ``geqrf``, ``ormqr``):
    ``(QR, QᵀA[:, k:])``, ``QR`` as ``geqrf`` leaves it (``R`` on and above the
    diagonal of its first ``min(m, k)`` rows, the reflectors below).  ``A`` is a scratch
    array: Fortran-ordered, it is overwritten (no copies)."""
    qr, tau, _, info = lapack.dgeqrf(A[:, :k], overwrite_a=1)
    if info:
        raise np.linalg.LinAlgError(f"geqrf: info {info}")
    rest = A[:, k:]
    if rest.shape[1]:
        rest, _, info = lapack.dormqr("L", "T", qr, tau, rest, lwork=max(1, 64 * rest.shape[1]),
                                      overwrite_c=1)
        if info:
            raise np.linalg.LinAlgError(f"ormqr: info {info}")
    return qr, rest


def chain_marginals(local: Array, glob: Array, base: Array, M: int
                    ) -> tuple[Array, Array, Array]:
    """``(Sigma, Cov_xL, Sigma_LL)``: every epoch's marginal (M, n, n), its covariance with
    the globals (M, n, g) and the globals' (g, g), by the sweep of the module docstring.

    Each step triangularises only the epoch columns ``[x_j, x_{j+1}]`` and applies the
    rotation to the global columns: the rows left with global entries only are a factor
    on the globals alone, set aside and triangularised once at the end.  Raises
    ``numpy.linalg.LinAlgError`` if an epoch or the globals are indeterminate.
    """
    n, g = local.shape[1] // 2, glob.shape[1]
    order = np.argsort(base, kind="stable")
    rows = np.hstack([local, glob])[order]
    cuts = np.r_[0, np.searchsorted(base[order], np.arange(1, M)), len(rows)]
    R_jj, R_jy = np.empty((M, n, n)), np.zeros((M, n, n + g))
    upper = np.triu(np.ones((2 * n, 2 * n)))  # masks the reflectors below R's diagonal
    carried = np.zeros((0, 2 * n + g))  # on [x_j, (x_{j+1} = 0), L]
    global_rows = []
    for j in range(M):
        last = j == M - 1
        c, m = len(carried), cuts[j + 1] - cuts[j]
        stacked = np.empty((c + m, 2 * n + g), order="F")
        stacked[:c], stacked[c:] = carried, rows[cuts[j]:cuts[j + 1]]
        if last:
            stacked = np.asfortranarray(np.delete(stacked, np.s_[n:2 * n], axis=1))
        k = n if last else 2 * n
        qr, rest = _triangularise(stacked, k)
        r = min(len(qr), k)
        if r < n:
            raise np.linalg.LinAlgError(f"epoch {j}: the marginal is indeterminate")
        R_jj[j] = qr[:n, :n] * upper[:n, :n]
        R_jy[j, :, n:] = rest[:n]
        if not last:
            R_jy[j, :, :n] = qr[:n, n:2 * n]
            carried = np.zeros((r - n, 2 * n + g))
            carried[:, :n] = qr[n:r, n:2 * n] * upper[n:r, n:2 * n]
            carried[:, 2 * n:] = rest[n:r]
        global_rows.append(rest[r:])
    bad = np.flatnonzero(np.any(np.diagonal(R_jj, axis1=1, axis2=2) == 0.0, axis=1))
    if len(bad):
        raise np.linalg.LinAlgError(f"epoch {bad[0]}: the marginal is indeterminate")
    if g:
        R_LL = np.linalg.qr(np.vstack(global_rows), mode="r")
        if R_LL.shape[0] < g or np.any(np.diagonal(R_LL) == 0.0):
            raise np.linalg.LinAlgError("the global variables are indeterminate")
        R_LL_inv = np.linalg.inv(R_LL[:g])
        S_LL = R_LL_inv @ R_LL_inv.T
    else:
        S_LL = np.zeros((0, 0))
    R_inv = np.linalg.inv(R_jj)
    K_all = R_inv @ R_jy
    own = R_inv @ np.swapaxes(R_inv, -1, -2)
    sig, cov_xl = np.empty((M, n, n)), np.empty((M, n, g))
    P = np.zeros((n + g, n + g))  # joint covariance of [x_{j+1}, L]
    P[n:, n:] = S_LL
    for j in range(M - 1, -1, -1):
        K = K_all[j]
        KP = K @ P
        sig[j] = own[j] + KP @ K.T
        cov_xl[j] = -KP[:, n:]
        P[:n, :n], P[:n, n:], P[n:, :n] = sig[j], cov_xl[j], cov_xl[j].T
    return 0.5 * (sig + np.swapaxes(sig, -1, -2)), cov_xl, S_LL
