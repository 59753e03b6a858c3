r"""Navigation state spaces implementing :class:`estimators.spaces.Space`.

:class:`UnitQuaternion` is the attitude space: ambient coordinates are a Hamilton unit
quaternion ``[w, x, y, z]`` (``q_nb``), tangent coordinates a body-frame rotation
vector, with the right-perturbation chart

.. math::

    q \boxplus \delta = q \otimes \mathrm{Exp}(\delta), \qquad
    p \boxminus q = \mathrm{Log}(q^* \otimes p),

the same as GTSAM's ``Rot3.retract`` / ``localCoordinates`` with the exponential map.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .quaternion import points_and_weights, qconj, qexp, qleft_matrix, qlog, qmul, qnormalize

Array = NDArray[np.float64]

#: Round-off floor of the weighted tangent sum, in units of eps * sum|w_i|.
_FLOOR_ULPS = 8.0

__all__ = ["UnitQuaternion"]


def _one(x: Array, y: Array) -> Array | None:
    """``x`` as one quaternion (4,) when it is one - (4,) or (1, 4) - and ``y`` a plain
    stack (m, k): then a product with it is one (m, 4) @ (4, 4) call; else ``None``."""
    if y.ndim != 2 or not (x.ndim == 1 or (x.ndim == 2 and x.shape[0] == 1)):
        return None
    return x.reshape(4)


def _log_rows(r: Array) -> Array:
    r""":func:`~nav.quaternion.qlog` of a stack of quaternions (m, 4) in fewer calls: the
    same :math:`2\,\mathrm{sign}(w)\operatorname{atan2}(\lVert v\rVert, |w|)\,v/\lVert v
    \rVert` without the small-angle series (``atan2`` keeps full relative accuracy for a
    small :math:`\lVert v\rVert`, and :math:`v = 0` gives 0)."""
    v, w = r[:, 1:], r[:, 0]
    n = np.sqrt(np.einsum("ij,ij->i", v, v))
    k = np.arctan2(n, np.abs(w)) / np.where(n > 0.0, n, 1.0)
    return (np.where(w < 0.0, -2.0, 2.0) * k)[:, None] * v


@dataclass(frozen=True)
class UnitQuaternion:
    r"""Attitude as a unit quaternion (ambient dim 4) with a 3-d rotation-vector chart.

    Parameters
    ----------
    tol : float
        Convergence threshold of :meth:`mean` on the norm of the update step (rad).
    max_iter : int
        Iteration limit of :meth:`mean`.

    Notes
    -----
    ``q`` and ``-q`` are the same attitude everywhere: :func:`~nav.quaternion.qlog`
    returns the short-way rotation vector, so :meth:`local` and :meth:`mean` are
    invariant to the sign of any input.
    """

    tol: float = 1e-13
    max_iter: int = 50

    @property
    def ambient_dim(self) -> int:
        return 4

    @property
    def dim(self) -> int:
        return 3

    def retract(self, x: ArrayLike, delta: ArrayLike) -> Array:
        r"""Right perturbation :math:`x \otimes \mathrm{Exp}(\delta)`, renormalised.

        Parameters
        ----------
        x : array_like, shape (..., 4)
            Unit quaternion(s).
        delta : array_like, shape (..., 3)
            Body-frame rotation vector(s); broadcast against ``x``.

        Returns
        -------
        ndarray, shape (..., 4)
        """
        x, delta = np.asarray(x, dtype=float), np.asarray(delta, dtype=float)
        one = _one(x, delta)
        if one is not None:  # one attitude, many perturbations
            e = qexp(delta) @ qleft_matrix(one).T
            return e / np.sqrt(np.einsum("ij,ij->i", e, e))[:, None]
        return qnormalize(qmul(x, qexp(delta)))

    def local(self, x: ArrayLike, y: ArrayLike) -> Array:
        r"""Body-frame rotation vector from ``x`` to ``y``: :math:`\mathrm{Log}(x^* \otimes y)`.

        The result has norm :math:`\le \pi`, and
        ``local(x, retract(x, δ)) == δ`` for :math:`|\delta| < \pi`.

        Shapes: ``x``, ``y`` (..., 4), broadcast against each other → (..., 3).
        """
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        one = _one(x, y)
        if one is not None:  # one reference, many attitudes
            return _log_rows(y @ qleft_matrix(qconj(one)).T)
        return qlog(qmul(qconj(x), y))

    def mean(self, points: ArrayLike, weights: ArrayLike) -> Array:
        r"""Weighted (Karcher) mean in the local chart, by fixed-point iteration.

        Starting from the weighted chordal mean of the points sign-aligned with the
        largest-weight point (the first on ties),

        .. math::

            \delta = \sum_i w_i\, \mathrm{Log}(q^* \otimes q_i), \qquad
            q \leftarrow q \otimes \mathrm{Exp}(\delta),

        until :math:`\lVert\delta\rVert <` ``tol`` (each batch element is frozen once
        it has converged).  When large positive and negative weights cancel (e.g.
        unscented rules with small :math:`\alpha`, :math:`\sum_i |w_i| \sim 10^6`) the
        round-off floor of the weighted sum, about :math:`10^{-16} \sum_i |w_i|`, can
        exceed ``tol``; an element is then also accepted once its step is below
        :math:`8\,\epsilon \sum_i |w_i|` *and* no longer shrinking (less than halved
        from the previous iteration), i.e. it has reached the noise floor.  For a
        convex combination this extra rule never fires before the ``tol`` rule.

        Parameters
        ----------
        points : array_like, shape (..., m, 4)
            Unit quaternions; the sign of each is irrelevant.
        weights : array_like, shape (m,) or (..., m)
            Weights summing to one; may be negative.  Broadcast against the batch
            axes of ``points``.

        Returns
        -------
        ndarray, shape (..., 4)
            Unit quaternion on the side of the largest-weight point.

        Raises
        ------
        ValueError
            On inconsistent shapes.
        ArithmeticError
            If the iteration has not converged after ``max_iter`` steps.
        """
        pts, w, m = points_and_weights(points, weights)
        if pts.ndim == 2 and w.ndim == 1:
            return self._mean_one(pts, w)
        batch = np.broadcast_shapes(pts.shape[:-2], w.shape[:-1])
        pts = np.broadcast_to(pts, batch + (m, 4))
        w = np.broadcast_to(w, batch + (m,))

        start = np.argmax(w, axis=-1)
        ref = np.take_along_axis(pts, start[..., None, None], axis=-2)  # (..., 1, 4)
        # start from the chordal mean of the points sign-aligned with ``ref``: within
        # O(spread³) of the Karcher mean, so tight clouds converge in one step
        aligned = pts * np.where(np.sum(pts * ref, axis=-1) < 0.0, -1.0, 1.0)[..., None]
        q = qnormalize(np.einsum("...m,...mi->...i", w, aligned))
        floor = _FLOOR_ULPS * np.finfo(np.float64).eps * np.sum(np.abs(w), axis=-1)
        done = np.zeros(batch, dtype=bool)
        prev = np.full(batch, np.inf)
        step_norm = prev
        for _ in range(self.max_iter):
            d = qlog(qmul(qconj(q)[..., None, :], pts))  # (..., m, 3)
            step = np.einsum("...m,...mi->...i", w, d)
            q = np.where(done[..., None], q, qnormalize(qmul(q, qexp(step))))
            step_norm = np.where(done, 0.0, np.linalg.norm(step, axis=-1))
            done |= (step_norm < self.tol) | ((step_norm <= floor) & (step_norm > 0.5 * prev))
            prev = step_norm
            if np.all(done):
                return q
        raise ArithmeticError(
            f"UnitQuaternion.mean did not converge in {self.max_iter} iterations "
            f"(largest last step {np.max(step_norm):.3e} rad, tolerance {self.tol:.1e} rad); "
            "the weighted cloud may be too spread out for the fixed-point iteration"
        )

    def _mean_one(self, pts: Array, w: Array) -> Array:
        """:meth:`mean` for one cloud ``(m, 4)``: the same iteration and stopping rules
        with scalar bookkeeping (the common case inside a filter, ~3× faster)."""
        ref = pts[int(np.argmax(w))]
        q = qnormalize(w @ (pts * np.where(pts @ ref < 0.0, -1.0, 1.0)[:, None]))
        floor = _FLOOR_ULPS * np.finfo(np.float64).eps * float(np.abs(w).sum())
        prev = step_norm = np.inf
        for _ in range(self.max_iter):
            step = w @ _log_rows(pts @ qleft_matrix(qconj(q)).T)
            q = qnormalize(qleft_matrix(q) @ qexp(step))
            step_norm = float(np.sqrt(step @ step))
            if step_norm < self.tol or (step_norm <= floor and step_norm > 0.5 * prev):
                return q
            prev = step_norm
        raise ArithmeticError(
            f"UnitQuaternion.mean did not converge in {self.max_iter} iterations "
            f"(last step {step_norm:.3e} rad, tolerance {self.tol:.1e} rad); "
            "the weighted cloud may be too spread out for the fixed-point iteration"
        )
