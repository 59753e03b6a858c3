r"""Odometry between the epochs of a planar log, and the frames of planar covariances.

The car model of :class:`~slam.kinds.planar.log.PlanarLog` is a right multiplication,
:math:`T_{k+1} = T_k\,M(u_k)`, so the motion between two epochs is the compounding of the
noisy controls from the identity pose (:func:`relative_motions`, with its first-order
covariance in closed form), and the path between the epochs of a smoothed estimate is
that compounding started from each epoch's pose (:func:`interpolate_reference`).
Covariances of ``[x, y, θ]`` move between GTSAM's body frame (right perturbation) and
the world frame with :math:`J = \mathrm{blkdiag}(R(θ), 1)`.  Used by the GTSAM reference
(:mod:`slam.kinds.planar.reference`) and the online rows.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from estimators import wrap_angle
from slam.kinds.planar.log import PlanarLog

if TYPE_CHECKING:
    from slam.kinds.planar.reference import PlanarReference

Array = NDArray[np.float64]


# --------------------------------------------------------------------------------------
# Frames


def _blkdiag_rot(theta: Array | float) -> Array:
    """``blkdiag(R(θ), 1)`` for an array of angles, shape ``(..., 3, 3)``."""
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    J = np.zeros((*theta.shape, 3, 3))
    J[..., 0, 0] = c
    J[..., 0, 1] = -s
    J[..., 1, 0] = s
    J[..., 1, 1] = c
    J[..., 2, 2] = 1.0
    return J


def body_to_world_cov(theta: Array | float, cov_body: Array) -> Array:
    """World-frame (x, y, θ) covariance(s) from body-frame (right-perturbation) ones.

    ``J Σ Jᵀ`` with ``J = blkdiag(R(θ), 1)``; broadcasts over leading axes.
    """
    J = _blkdiag_rot(theta)
    return J @ cov_body @ np.swapaxes(J, -1, -2)


def world_to_body_cov(theta: Array | float, cov_world: Array) -> Array:
    """Inverse of :func:`body_to_world_cov`."""
    J = _blkdiag_rot(theta)
    return np.swapaxes(J, -1, -2) @ cov_world @ J


# --------------------------------------------------------------------------------------
# Odometry compounding


def epoch_steps_of(log: PlanarLog) -> NDArray[np.int64]:
    """Steps that carry a pose variable: 0, every step with observations, and ``K``."""
    K = log.n_steps
    steps = np.array(sorted({0, K, *log.observations_at().keys()}), dtype=np.int64)
    if steps[0] < 0 or steps[-1] > K:
        raise ValueError(f"observation steps must lie in [0, {K}], got {steps[0]}..{steps[-1]}")
    return steps


def _scan(controls: Array, dt: float, wheelbase: float, epoch_steps: NDArray[np.int64]):
    """Compound the controls from the identity at every epoch, all segments at once.

    Returns ``seg`` (K,) segment of each step, ``start`` (K,) first step of that segment,
    ``phi`` (K,) heading before each step relative to its segment start, ``C`` (K+1,) and
    ``D`` (K+1, 2) exclusive cumulative sums of heading and position increments, each
    increment expressed in its own segment's start frame (so differences of ``C`` / ``D``
    inside one segment are relative headings / positions in that segment's frame).
    """
    K = controls.shape[0]
    V, G = controls[:, 0], controls[:, 1]
    seg = np.searchsorted(epoch_steps, np.arange(K), side="right") - 1
    start = epoch_steps[seg]
    C = np.concatenate(([0.0], np.cumsum(V * dt * np.sin(G) / wheelbase)))
    phi = C[:-1] - C[start]
    a = G + phi
    inc = (V * dt)[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
    D = np.concatenate((np.zeros((1, 2)), np.cumsum(inc, axis=0)))
    return seg, start, phi, C, D


def relative_motions(
    controls: Array,
    control_cov: Array,
    dt: float,
    wheelbase: float,
    epoch_steps: NDArray[np.int64],
) -> tuple[Array, Array]:
    r"""Relative poses between consecutive epochs and their first-order covariances.

    Parameters
    ----------
    controls : (K, 2) array
        Noisy ``[V, G]`` per step.
    control_cov : (2, 2) array
        Covariance of the control noise of one step.
    epoch_steps : (E,) int array
        Increasing steps, ``epoch_steps[0] = 0`` and ``epoch_steps[-1] = K``.

    Returns
    -------
    rel : (E-1, 3) array
        ``[x, y, θ]`` of the motion from epoch ``e`` to ``e+1`` in the frame of epoch
        ``e`` (θ not wrapped).
    cov : (E-1, 3, 3) array
        Its covariance in GTSAM's between-factor tangent (body frame of ``rel``, right
        perturbation), without any lateral sigma or floor.

    Notes
    -----
    With :math:`p_k` the positions of the compounding inside a segment ending at step
    :math:`b`, the car model's state Jacobian is :math:`F_k = [[I, J(p_{k+1}-p_k)],[0, 1]]`
    (:math:`J(v) = (-v_y, v_x)`), so :math:`F_{b-1}\cdots F_{k+1} =
    [[I, J(p_b - p_{k+1})],[0, 1]]` and the world-coordinate covariance is
    :math:`\sum_k \Phi_k B_k Q B_k^\top \Phi_k^\top` (:math:`B_k` the control Jacobian):
    one vectorised pass, no loop.
    """
    controls = np.asarray(controls, dtype=float)
    epoch_steps = np.asarray(epoch_steps, dtype=np.int64)
    K = controls.shape[0]
    if epoch_steps[0] != 0 or epoch_steps[-1] != K or np.any(np.diff(epoch_steps) <= 0):
        raise ValueError("epoch_steps must increase strictly from 0 to K")
    seg, start, phi, C, D = _scan(controls, dt, wheelbase, epoch_steps)
    ends = epoch_steps[1:]
    starts = epoch_steps[:-1]
    rel = np.empty((len(ends), 3))
    rel[:, :2] = D[ends] - D[starts]
    rel[:, 2] = C[ends] - C[starts]

    V, G = controls[:, 0], controls[:, 1]
    a = G + phi
    ca, sa = np.cos(a), np.sin(a)
    B = np.empty((K, 3, 2))
    B[:, 0, 0] = dt * ca
    B[:, 0, 1] = -V * dt * sa
    B[:, 1, 0] = dt * sa
    B[:, 1, 1] = V * dt * ca
    B[:, 2, 0] = dt * np.sin(G) / wheelbase
    B[:, 2, 1] = V * dt * np.cos(G) / wheelbase
    lever = D[epoch_steps[seg + 1]] - D[1:]  # p_b - p_{k+1}, per step
    Gm = B.copy()
    Gm[:, 0, :] -= lever[:, 1, None] * B[:, 2, :]
    Gm[:, 1, :] += lever[:, 0, None] * B[:, 2, :]
    contrib = Gm @ np.asarray(control_cov, dtype=float) @ np.swapaxes(Gm, 1, 2)
    cov_world = np.add.reduceat(contrib, starts, axis=0)
    return rel, world_to_body_cov(rel[:, 2], cov_world)


def _compound_world(base: Array, rel_xy: Array, rel_th: Array) -> Array:
    """World poses ``base ∘ rel`` (rows), θ wrapped."""
    c, s = np.cos(base[:, 2]), np.sin(base[:, 2])
    out = np.empty((len(base), 3))
    out[:, 0] = base[:, 0] + c * rel_xy[:, 0] - s * rel_xy[:, 1]
    out[:, 1] = base[:, 1] + s * rel_xy[:, 0] + c * rel_xy[:, 1]
    out[:, 2] = wrap_angle(base[:, 2] + rel_th)
    return out


def interpolate_reference(ref: PlanarReference, log: PlanarLog) -> Array:
    """The smoother's path at every step, ``(K+1, 3)`` rows ``[x, y, θ]``.

    Epoch steps carry the smoothed poses; in between, the noisy controls are compounded
    forward from the smoothed pose of the preceding epoch.
    """
    steps = np.asarray(ref.epoch_steps, dtype=np.int64)
    K = log.n_steps
    if steps[0] != 0 or steps[-1] != K:
        raise ValueError("reference epochs do not span this log")
    out = np.empty((K + 1, 3))
    if K > 0:
        seg, start, _, C, D = _scan(np.asarray(log.controls, float), log.dt, log.wheelbase, steps)
        out[1:] = _compound_world(ref.poses[seg], D[1:] - D[start], C[1:] - C[start])
    out[steps] = ref.poses
    return out
