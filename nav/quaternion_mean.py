r"""Weighted quaternion mean by the eigenvector (Lagrange-multiplier) method, [Ding 2017] §1.4.

For unit quaternions :math:`q_i` with weights :math:`w_i` (:math:`\sum_i w_i = 1`) the
mean minimises the weighted chordal cost

.. math::

    J(q) = \sum_i w_i \big(1 - (q_i^\top q)^2\big) = \sum_i w_i - q^\top M q,
    \qquad M = \sum_i w_i\, q_i q_i^\top ,

subject to :math:`q^\top q = 1`.  With a Lagrange multiplier :math:`\lambda`,
:math:`\partial/\partial q\,[q^\top M q + \lambda(1 - q^\top q)] = 0` gives
:math:`M q = \lambda q`: the stationary points are the unit eigenvectors of :math:`M`
and :math:`J = \sum w - \lambda`, so the minimiser is the eigenvector of the *largest*
eigenvalue.  (The paper's matrix :math:`L` is built from the error-quaternion vector
parts :math:`\delta\vartheta_i = \Xi(q_i)^\top q`, and
:math:`\lVert\Xi(q_i)^\top q\rVert^2 = 1 - (q_i^\top q)^2`, so its
:math:`L = (\sum w) I - M` and the paper's "smallest eigenvalue of :math:`L`" is the
largest of :math:`M`.)  :math:`M` is unchanged by :math:`q_i \to -q_i`, so the mean is
free of the quaternion sign ambiguity; its own sign is chosen to agree with the
largest-weight point (as :meth:`nav.spaces.UnitQuaternion.mean` does).

Negative weights (unscented rules with a negative centre weight, HoMM with
:math:`n > 3`): :math:`M` is then indefinite, but the stationarity argument is unchanged
and the minimiser of :math:`J` is still the eigenvector of the largest (most positive)
eigenvalue.  For a cloud of spread :math:`\sigma` around :math:`\bar q`,
:math:`M = (\sum_i w_i)\,\bar q\bar q^\top + O(\sum_i |w_i|\,\sigma^2)`, so the top
eigenvalue is :math:`\approx 1` and well separated from the others (all
:math:`O(\sum|w_i|\sigma^2)`) as long as :math:`\sum_i |w_i|\,\sigma^2 \ll 1`.  If the top
eigenvalue is not separated (relative gap below ``gap_tol``, e.g. two equal-weight
attitudes 180° apart, or negative weights dominating) the mean is not defined and
:func:`eigen_mean` raises :class:`ArithmeticError` instead of returning an arbitrary
eigenvector.

Relation to the iterative chart mean: both give the centre of a symmetric set exactly;
for a general cloud of spread :math:`\sigma` they differ by :math:`O(\sigma^3)` (the chordal
and geodesic costs agree to fourth order in the angles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .quaternion import points_and_weights
from .spaces import UnitQuaternion

Array = NDArray[np.float64]

__all__ = ["EigenMeanQuaternion", "eigen_mean"]


def eigen_mean(points: ArrayLike, weights: ArrayLike, gap_tol: float = 1e-12) -> Array:
    r"""Weighted quaternion mean: top eigenvector of :math:`\sum_i w_i q_i q_i^\top`.

    Parameters
    ----------
    points : array_like, shape (..., m, 4)
        Unit quaternions (scalar first); their signs are irrelevant.
    weights : array_like, shape (m,) or (..., m)
        Weights (should sum to one; may be negative).  Broadcast against the batch axes.
    gap_tol : float
        Smallest accepted gap between the two largest eigenvalues, relative to
        :math:`\sum_i |w_i|`.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion, sign chosen so that its dot product with the largest-weight
        point (the first on ties) is non-negative.

    Raises
    ------
    ValueError
        On inconsistent shapes.
    ArithmeticError
        If the largest eigenvalue is not simple (the mean is not unique).
    """
    pts, w, m = points_and_weights(points, weights)
    batch = np.broadcast_shapes(pts.shape[:-2], w.shape[:-1])
    pts = np.broadcast_to(pts, batch + (m, 4))
    w = np.broadcast_to(w, batch + (m,))

    M = np.einsum("...m,...mi,...mj->...ij", w, pts, pts)
    lam, V = np.linalg.eigh(0.5 * (M + np.swapaxes(M, -1, -2)))  # ascending
    gap = lam[..., -1] - lam[..., -2]
    scale = np.sum(np.abs(w), axis=-1)
    if np.any(~(gap > gap_tol * scale)):
        raise ArithmeticError(
            "eigenvector quaternion mean is not unique: the two largest eigenvalues of "
            f"sum_i w_i q_i q_i^T differ by {np.min(gap):.3e} (relative tolerance "
            f"{gap_tol:.1e}); the attitudes are too spread out or the weights degenerate")
    q = V[..., :, -1]
    start = np.take_along_axis(pts, np.argmax(w, axis=-1)[..., None, None], axis=-2)[..., 0, :]
    sign = np.where(np.sum(q * start, axis=-1) < 0.0, -1.0, 1.0)
    q = q * sign[..., None]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@dataclass(frozen=True)
class EigenMeanQuaternion(UnitQuaternion):
    """:class:`nav.spaces.UnitQuaternion` whose :meth:`mean` is :func:`eigen_mean`.

    ``retract`` and ``local`` are the parent's (right perturbation
    :math:`q \\otimes \\mathrm{Exp}(\\delta)`); the mean is closed-form (one 4x4 symmetric
    eigen-decomposition, no iteration).
    """

    gap_tol: float = 1e-12

    def mean(self, points: ArrayLike, weights: ArrayLike) -> Array:
        return eigen_mean(points, weights, self.gap_tol)
