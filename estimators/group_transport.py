r"""Invariant filtering with the covariance kept in the world chart: the correction made on
the group and the covariance transported to the new estimate (local mode's invariant
variants, :mod:`estimators.partitioned`).

A group space (:class:`~estimators.slam_group.SlamGroup`,
:class:`~nav.extended_pose_group.ExtendedPoseGroup`) relates its error :math:`ξ`
to the world-chart error by :math:`δ = M(x)ξ` (``to_world``).  A filter holding the
world-chart covariance :math:`P_w(x) = M(x) P_ξ M(x)^\top` is the invariant filter if, each
time the estimate moves without new information (a correction), the mean moves on the group,
:math:`x^+ = x \boxplus M(x)^{-1} δ_w` (:func:`retract_world`), and the covariance follows
with the error held fixed, :math:`P' = T P T^\top`, :math:`T = M(x^+) M(x)^{-1}`
(:func:`transport`).  For the EKF this is exact: its prediction
:math:`F_ξ = M(y)^{-1} F M(x)` and update :math:`K_ξ = M(x)^{-1} K_w` are the standard ones
seen in the world chart; only the move of the estimate differs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .linalg import Array


def retract_world(space: Any, x: Array, delta_w: Array) -> Array:
    r""":math:`x \boxplus M(x)^{-1} δ_w`: a correction ``delta_w`` (world chart) made on the
    group."""
    d = space.from_world(x, np.asarray(delta_w, dtype=float)[..., None])[..., 0]
    return space.retract(np.asarray(x, dtype=float), d)


def transport(space: Any, x_old: Array, x_new: Array, cov: Array | None = None,
              sqrt: Array | None = None, lead: int | None = None) -> Array:
    r""":math:`P' = T P T^\top`, :math:`T = M(x_{new}) M(x_{old})^{-1}`: the dense ``cov``
    transported, or a lower-triangular factor of it from the factor ``sqrt``.

    ``lead``: with the right error :math:`T` adds to every row multiples of the rotation rows
    (and rotates those), so :math:`T = I + E` with :math:`E` zero past the rotation's last
    column ``lead``.  Dense: :math:`P' = P + E P_{l\cdot} + (E P_{l\cdot})^\top + E P_{ll}
    E^\top` (:math:`O(\mathrm{lead}\cdot d^2)`).  Factor: the rotation rows of a
    lower-triangular factor with the vehicle first are zero past that column, so only the
    first ``lead`` columns change, to :math:`S_{\cdot l} + E S_{ll}`, and one LQ of their
    leading square restores the triangle (:math:`O(d)` arithmetic).  :math:`E` (d, lead)
    is the space's ``transport_columns(x_old, x_new)`` when it has one, else :math:`T`
    applied to those columns.  ``None``: :math:`T(TP)^\top`, and the space's own
    ``lower_factor`` re-triangularises :math:`TS`."""
    x_old, x_new = np.asarray(x_old, dtype=float), np.asarray(x_new, dtype=float)
    columns = None if lead is None else getattr(space, "transport_columns", None)

    def T(A: Array) -> Array:
        return space.to_world(x_new, space.from_world(x_old, A))

    if cov is not None:
        P = np.asarray(cov, dtype=float)
        if lead is None:
            return T(T(P).T)
        # T = I + E with E zero past column ``lead``: P' = P + EP_l + (EP_l)ᵀ + E P_ll Eᵀ
        if columns is not None:
            E = columns(x_old, x_new)
        else:
            E = T(np.eye(P.shape[0], lead))
            E[:lead] -= np.eye(lead)
        EP = E @ P[:lead]
        out = P + EP
        out += EP.T
        out += E @ P[:lead, :lead] @ E.T
        return out
    if lead is None:
        return space.lower_factor(T(np.asarray(sqrt, dtype=float)))
    S = np.array(sqrt, dtype=float, copy=True)
    lead_cols = T(S[:, :lead]) if columns is None else \
        S[:, :lead] + columns(x_old, x_new) @ S[:lead, :lead]
    S[:, :lead] = lower_block(lead_cols)
    return S


def lower_block(cols: Array) -> Array:
    """``cols @ Q`` (n, k) with its leading (k, k) square made lower triangular (LQ),
    positive diagonal, exact zeros above it."""
    k = cols.shape[1]
    Q, R = np.linalg.qr(cols[:k].T)
    out = cols @ (Q * np.where(np.diagonal(R) < 0.0, -1.0, 1.0))
    out[:k] = np.tril(out[:k])
    return out


class WorldChartGroup:
    """What a group space with ``to_world`` / ``from_world`` / ``retract`` gains for local
    mode: :meth:`retract_world` and :meth:`transport`.  The space says which leading tangent
    columns a right-error transport touches (``transport_lead``; ``None``: its own
    ``lower_factor`` re-triangularises) and may give :math:`T - I` on them in closed form
    (``transport_columns(x_old, x_new)``, (d, lead); :func:`transport`)."""

    transport_lead: int | None

    def retract_world(self, x: Array, delta_w: Array) -> Array:
        """A world-chart correction made on the group (:func:`retract_world`)."""
        return retract_world(self, x, delta_w)

    def transport(self, x_old: Array, x_new: Array, cov: Array | None = None,
                  sqrt: Array | None = None) -> Array:
        """A world-chart covariance (or its lower factor) carried from ``x_old`` to
        ``x_new`` with the group error fixed (:func:`transport`)."""
        return transport(self, x_old, x_new, cov, sqrt, lead=self.transport_lead)
