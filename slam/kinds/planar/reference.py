r"""The batch-optimal yardstick for planar SLAM logs: a GTSAM factor-graph smoother.

:func:`smooth_planar` runs a factor-graph smoother over the very measurements a filter
sees in a :class:`~slam.kinds.planar.log.PlanarLog` and returns the maximum a-posteriori poses and
landmarks, with their marginal covariances.  The graph has

- a pose variable :math:`T_e \in SE(2)` (gtsam key ``X(k)``, ``k`` the *step number*) at
  every **epoch**: step 0, every step with observations, and the final step ``K``;
- a point variable :math:`l_j \in \mathbb{R}^2` (key ``L(j)``, ``j`` the landmark id) for
  every landmark that was observed;
- a prior on the first pose, one odometry (between) factor per pair of consecutive
  epochs and one bearing-range factor per observation.

It minimises (``objective`` = :math:`\tfrac12\chi^2` = ``graph.error(values)``)

.. math::

    \tfrac12\chi^2 =
    \tfrac12\,\lVert \mathrm{Log}(\bar T_0^{-1} T_0) \rVert^2_{\Sigma_0}
    + \tfrac12 \sum_{e} \lVert \mathrm{Log}(\Delta_e^{-1}\, T_e^{-1} T_{e+1})
      \rVert^2_{\Sigma_{\Delta,e}}
    + \tfrac12 \sum_{m} \Bigl\lVert
      \begin{bmatrix} \mathrm{wrap}(\beta(T_{e_m}, l_{j_m}) - b_m) \\
                      \lVert T_{e_m}^{-1} l_{j_m} \rVert - r_m \end{bmatrix}
      \Bigr\rVert^2_{R_{br}},

with :math:`\lVert v\rVert^2_\Sigma = v^\top\Sigma^{-1}v`, :math:`\bar T_0` = ``log.x0``,
:math:`\beta(T, l)` the bearing of :math:`l` in the body frame of :math:`T`, and
:math:`(r_m, b_m)` the measured range and bearing, and :math:`R_{br}` ``log.obs_cov``
reordered to GTSAM's [bearing, range] (the log stores [range, bearing]).

Odometry factors
    Between epochs :math:`e` and :math:`e+1` the car model of
    :class:`~slam.kinds.planar.log.PlanarLog`
    is a right multiplication, :math:`T_{k+1} = T_k\,M(u_k)` with
    :math:`M(V, G) = (V\,dt\cos G,\; V\,dt\sin G,\; V\,dt\sin G / WB)`, so the relative
    motion :math:`\Delta_e = M(u_a)\cdots M(u_{b-1})` is the compounding of the noisy
    controls from the identity pose, whatever the absolute pose.  Its covariance is the
    first-order propagation of ``log.control_cov`` through that compounding, done in closed
    form (the product of the state Jacobians of the car model is a shear, see
    :func:`~slam.kinds.planar.odometry.relative_motions`), in (x, y, θ) coordinates of the
    earlier pose's frame, then taken into GTSAM's between-factor tangent (right
    perturbation, body frame of :math:`\Delta_e`) with
    :math:`J = \mathrm{blkdiag}(R(\theta_\Delta)^\top, 1)`; the difference between
    ``Pose2.Logmap`` and these plain local coordinates is second order.
    The propagated covariance is rank-deficient (two noise inputs per step: a one-step
    motion has a 2-D covariance) so a small lateral (body-y) standard deviation
    ``lateral_sigma_m`` is added to every odometry factor (default 1 mm per factor, in
    quadrature, whatever the factor's length: a millimetre of unmodelled side slip, well
    below the ~12 mm lateral spread that σ_G = 3° gives over 8 steps at 3 m/s, so the
    smoother is not perceptibly detuned), and a variance of ``SIGMA_FLOOR² = (1e-6)²``
    (m², m², rad²) on the diagonal keeps stationary segments (``V = 0``: zero covariance)
    finite.

Prior
    ``log.P0`` is a world-frame (x, y, φ) covariance; it is taken into the body-frame
    tangent of ``PriorFactorPose2`` with :math:`J^{-1} = \mathrm{blkdiag}(R(φ_0)^\top, 1)`
    and ``SIGMA_FLOOR² = (1e-6)²`` is added to its diagonal, so that
    ``P0 = 0`` (a known start, as in Bailey's simulator) becomes a very stiff prior rather
    than a hard constraint: one code path for every ``P0``, including a singular non-zero,
    non-diagonal one (some directions known exactly, others not) that
    ``noiseModel.Constrained`` cannot express; its effect on the estimate is ~1e-6.

Solving
    Plain Levenberg-Marquardt from dead reckoning falls into wrong minima on long logs, so
    the epochs are fed to iSAM2 in chunks of ``DEFAULT_CHUNK`` (each new pose initialised
    by composing the odometry onto the previous one: the current estimate at a chunk's
    start, dead reckoning inside it; each new landmark from its first observation; no
    relinearisation), and the iSAM2 estimate is polished by a batch Levenberg-Marquardt
    run, which relinearises every factor.  ``chunk = 1`` is the epoch path (an update, a
    relinearisation check and the current pose after every epoch) the online row
    (:mod:`slam.kinds.planar.online`) runs; both reach the same optimum (``½χ²`` equal to
    ~1e-11 relative on bailey, webmap, densemap).  Both objectives are reported.

Covariances
    GTSAM's marginal of a ``Pose2`` is in its body frame (right perturbation
    :math:`T\,\mathrm{Exp}(\xi)`).  ``PlanarReference.pose_cov`` holds **world-frame**
    (x, y, θ) covariances, :math:`J\,\Sigma_{body}\,J^\top` with
    :math:`J = \mathrm{blkdiag}(R(θ), 1)`, directly comparable with a filter's covariance of
    ``[x, y, φ]``.  Landmark covariances need no conversion (``Point2`` is a vector space).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X
from numpy.typing import NDArray

from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.odometry import (
    body_to_world_cov,
    epoch_steps_of,
    relative_motions,
    world_to_body_cov,
)

Array = NDArray[np.float64]

#: Default extra lateral (body-y) standard deviation of every odometry factor (m).
DEFAULT_LATERAL_SIGMA_M = 1e-3
#: Standard-deviation floor (m, m, rad) added to the prior and to odometry covariances.
SIGMA_FLOOR = 1e-6


@dataclass(frozen=True)
class PlanarReference:
    """The smoother's estimate of a :class:`~slam.kinds.planar.log.PlanarLog`.

    Attributes
    ----------
    epoch_steps : (E,) int array
        Steps of the pose variables: 0, every step with observations, and ``K``.
    poses : (E, 3) array
        Smoothed poses ``[x, y, θ]``, θ wrapped to ``(-π, π]``.
    landmark_ids : (L,) int array
        Ids of the observed landmarks, ascending.
    landmarks : (L, 2) array
        Smoothed landmark positions, in the order of ``landmark_ids``.
    pose_cov : (E, 3, 3) array or None
        World-frame ``(x, y, θ)`` marginal covariances of the poses (``None`` when
        marginals were not asked for).
    landmark_cov : (L, 2, 2) array or None
        Marginal covariances of the landmarks.
    objective : float
        ``½χ²`` (``graph.error``) at the final (iSAM2 + LM) estimate.
    objective_isam2 : float
        ``½χ²`` at the iSAM2 estimate, before the Levenberg-Marquardt polish.
    time_solve_s : float
        Wall time of building the graph, iSAM2 and the LM polish.
    time_marginals_s : float
        Wall time of the marginal covariances (0 without them).
    time_s : float
        Wall time of the whole call.
    """

    epoch_steps: NDArray[np.int64]
    poses: Array
    landmark_ids: NDArray[np.int64]
    landmarks: Array
    pose_cov: Array | None
    landmark_cov: Array | None
    objective: float
    objective_isam2: float
    time_solve_s: float
    time_marginals_s: float
    time_s: float


# --------------------------------------------------------------------------------------
# The smoother


def obs_noise_model(obs_cov: Array) -> gtsam.noiseModel.Base:
    """Noise of a BearingRangeFactor2D: GTSAM orders it [bearing, range], the log [r, b]."""
    cov = np.asarray(obs_cov, dtype=float)[np.ix_([1, 0], [1, 0])]
    if cov[0, 1] == 0.0:
        return gtsam.noiseModel.Diagonal.Sigmas(np.sqrt(np.diag(cov)))
    return gtsam.noiseModel.Gaussian.Covariance(cov)


def _epoch_factors(log: PlanarLog, k: int, sl: slice | None, pose_est, obs_noise,
                   seen: set[int], new_f, new_v) -> None:
    """``BearingRangeFactor2D`` per sighting at step ``k``; a new landmark starts at its
    first sighting."""
    if sl is None:
        return
    for j, (r, b) in zip(log.obs_id[sl], log.obs[sl], strict=True):
        j = int(j)
        new_f.add(gtsam.BearingRangeFactor2D(X(k), L(j), gtsam.Rot2(float(b)), float(r),
                                             obs_noise))
        if j not in seen:
            seen.add(j)
            new_v.insert(L(j), pose_est.transformFrom(np.array([r * np.cos(b), r * np.sin(b)])))


#: Epochs per iSAM2 update in the final smoother's default (chunked) path; 1 is the epoch
#: path the online row needs (an update, and the current pose, after every epoch).
DEFAULT_CHUNK = 64


def isam2_params(relinearize: bool = True) -> gtsam.ISAM2Params:
    """iSAM2's settings: relinearisation checked at every update (the epoch path, whose
    per-epoch estimate the online row scores), or none at all (``relinearize=False``, the
    chunked path: every factor stays linearised at its initial values and the LM polish
    relinearises the whole graph; the same optimum as the epoch path, ½χ² within 2.1e-11
    relative on the bundled planar worlds)."""
    params = gtsam.ISAM2Params()
    # check every update; LM polishes the rest (an infinite threshold: never)
    params.setRelinearizeThreshold(0.1 if relinearize else float("inf"))
    params.relinearizeSkip = 1
    return params


@dataclass(frozen=True)
class GraphInputs:
    """What the graph of a log is built from: the epoch steps, the relative motions and
    their covariances (lateral σ and floor included), the prior factor."""

    steps: NDArray[np.int64]
    rel: Array
    rel_cov: Array
    prior: gtsam.PriorFactorPose2


def graph_inputs(log: PlanarLog, lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M
                 ) -> GraphInputs:
    """The epochs, odometry factors' means and covariances and the prior of ``log``'s graph
    (module docstring)."""
    steps = epoch_steps_of(log)
    rel, rel_cov = relative_motions(log.controls, log.control_cov, log.dt, log.wheelbase, steps)
    floor = np.eye(3) * SIGMA_FLOOR**2
    lateral = np.diag([0.0, lateral_sigma_m**2, 0.0])
    x0 = np.asarray(log.x0, dtype=float)
    prior_cov = world_to_body_cov(x0[2], np.asarray(log.P0, dtype=float)) + floor
    prior = gtsam.PriorFactorPose2(
        X(0), gtsam.Pose2(*x0), gtsam.noiseModel.Gaussian.Covariance(prior_cov)
    )
    return GraphInputs(steps, rel, rel_cov + lateral + floor, prior)


def epoch_factors(log: PlanarLog, g: GraphInputs, e: int, pose_est: gtsam.Pose2,
                  seen: set[int], by_step: dict, obs_noise
                  ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values, gtsam.Pose2]:
    """Epoch ``e``'s new factors (the prior or its odometry factor, its sightings) and
    values: its pose initialised as ``pose_est`` (the previous pose's estimate) composed
    with the odometry, each new landmark from its first sighting; -> also that initial
    pose."""
    k = int(g.steps[e])
    new_f = gtsam.NonlinearFactorGraph()
    new_v = gtsam.Values()
    if e == 0:
        new_f.add(g.prior)
    else:
        delta = gtsam.Pose2(*g.rel[e - 1])
        noise = gtsam.noiseModel.Gaussian.Covariance(g.rel_cov[e - 1])
        new_f.add(gtsam.BetweenFactorPose2(X(int(g.steps[e - 1])), X(k), delta, noise))
        pose_est = pose_est.compose(delta)
    new_v.insert(X(k), pose_est)
    _epoch_factors(log, k, by_step.get(k), pose_est, obs_noise, seen, new_f, new_v)
    return new_f, new_v, pose_est


def incremental(log: PlanarLog, g: GraphInputs, chunk: int = DEFAULT_CHUNK,
                on_epoch: Callable[[int, int, gtsam.ISAM2], None] | None = None
                ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.ISAM2, set[int]]:
    """The graph fed to iSAM2 ``chunk`` epochs per update.

    Each new pose is initialised by composing the odometry onto the previous pose: the
    current iSAM2 estimate at a chunk's start, dead reckoning inside a chunk.  With
    ``chunk = 1`` (the epoch path) iSAM2 is updated and asked for the current pose after
    every epoch, and ``on_epoch(e, k, isam)`` is called after each update; only that path
    relinearises (:func:`isam2_params`).
    """
    if chunk < 1:
        raise ValueError(f"chunk must be >= 1, got {chunk}")
    isam = gtsam.ISAM2(isam2_params(relinearize=chunk == 1))
    graph = gtsam.NonlinearFactorGraph()
    seen: set[int] = set()
    pose_est = gtsam.Pose2(*np.asarray(log.x0, dtype=float))
    by_step = log.observations_at()
    obs_noise = obs_noise_model(log.obs_cov)
    E = len(g.steps)
    for e0 in range(0, E, chunk):
        new_f = gtsam.NonlinearFactorGraph()
        new_v = gtsam.Values()
        for e in range(e0, min(e0 + chunk, E)):
            f, v, pose_est = epoch_factors(log, g, e, pose_est, seen, by_step, obs_noise)
            new_f.push_back(f)
            new_v.insert(v)
        graph.push_back(new_f)
        isam.update(new_f, new_v)
        last = min(e0 + chunk, E) - 1
        pose_est = isam.calculateEstimatePose2(X(int(g.steps[last])))
        if on_epoch is not None and chunk == 1:
            on_epoch(e0, int(g.steps[e0]), isam)
    return graph, isam, seen


def smooth_planar(
    log: PlanarLog,
    *,
    lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M,
    marginals: bool = True,
    chunk: int = DEFAULT_CHUNK,
) -> PlanarReference:
    """Smooth a planar SLAM log with GTSAM (iSAM2 over the epochs, ``chunk`` epochs per
    update, then an LM polish).

    See the module docstring for the graph, the objective and the frames.  Pose
    covariances in the result are **world-frame** ``(x, y, θ)``, converted from GTSAM's
    body-frame marginals with ``J = blkdiag(R(θ), 1)``.
    """
    t_start = time.perf_counter()
    g = graph_inputs(log, lateral_sigma_m)
    graph, isam, seen = incremental(log, g, chunk)
    return polish(graph, isam, seen, g.steps, marginals, t_start)


def polish(graph: gtsam.NonlinearFactorGraph, isam: gtsam.ISAM2, seen: set[int],
           steps: NDArray[np.int64], marginals: bool, t_start: float) -> PlanarReference:
    """The LM polish of an iSAM2 pass over ``graph`` and the marginals, as a
    :class:`PlanarReference` (its times counted from ``t_start``)."""
    est_isam = isam.calculateEstimate()
    objective_isam2 = float(graph.error(est_isam))
    lm_params = gtsam.LevenbergMarquardtParams()
    lm_params.setRelativeErrorTol(1e-10)
    lm_params.setAbsoluteErrorTol(1e-12)
    lm_params.setMaxIterations(100)
    values = gtsam.LevenbergMarquardtOptimizer(graph, est_isam, lm_params).optimize()
    objective = float(graph.error(values))

    poses = np.array([_pose_row(values.atPose2(X(int(k)))) for k in steps]).reshape(-1, 3)
    ids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([values.atPoint2(L(int(j))) for j in ids], dtype=float).reshape(-1, 2)
    t_solved = time.perf_counter()

    pose_cov = landmark_cov = None
    if marginals:
        marg = gtsam.Marginals(graph, values)
        body = np.array([marg.marginalCovariance(X(int(k))) for k in steps]).reshape(-1, 3, 3)
        pose_cov = body_to_world_cov(poses[:, 2], body)
        landmark_cov = np.array(
            [marg.marginalCovariance(L(int(j))) for j in ids], dtype=float
        ).reshape(-1, 2, 2)
    t_end = time.perf_counter()

    return PlanarReference(
        epoch_steps=steps,
        poses=poses,
        landmark_ids=ids,
        landmarks=lms,
        pose_cov=pose_cov,
        landmark_cov=landmark_cov,
        objective=objective,
        objective_isam2=objective_isam2,
        time_solve_s=t_solved - t_start,
        time_marginals_s=t_end - t_solved,
        time_s=t_end - t_start,
    )


def _pose_row(p: gtsam.Pose2) -> tuple[float, float, float]:
    return (p.x(), p.y(), p.theta())
