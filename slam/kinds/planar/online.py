r"""Online estimators from the smoother's graph: iSAM2's current pose after every epoch
(the online optimum, row ``isam2``) and fixed-lag smoothers (rows ``fls-<lag>s``).

A filter's estimate at epoch :math:`k` uses the measurements up to :math:`k`.  The best an
online Gaussian estimator can do there is the MAP estimate of pose :math:`k` given those
measurements, :math:`\hat T_{k|k} = \arg\max p(T_{0:k}, l \mid z_{1:k}, u_{0:k})`
restricted to :math:`T_k`, with its marginal covariance: what iSAM2 gives after each
update over the graph of :mod:`slam.kinds.planar.reference` (the same factors, fed with
``chunk = 1``).  A filter is therefore judged against this row (same information, same
time), while the map, estimated once at the end, is judged against the smoother's final
marginals.

A fixed-lag smoother of lag :math:`\lambda` seconds (GTSAM's ``BatchFixedLagSmoother``:
Levenberg-Marquardt over the window after every epoch, :data:`FLS_RELATIVE_TOL`) keeps the
poses of the last :math:`\lambda` seconds and the whole map: each epoch re-stamps every
mapped landmark with the current time, so only poses are marginalised.  With GTSAM's
default ``enforceConsistency`` (not settable from Python) every variable a marginal factor
touches - here the whole map and the window's oldest pose - keeps the linearisation point
it had then, in every factor on it: first-estimates Jacobians for the window, as in
ekf-fej.  After a loop closure the map's estimates move metres away from those points (a
webmap run: median 3.7 m, largest 7.1 m; ``python -m benchmarks.fixed_lag_check``) and a
short lag's row turns optimistic.  Relinearising every factor but the marginal priors
instead (that benchmark's window) is worse on the same run - NEES/3 9.9 against GTSAM's
1.17 at 2 s, 10.4 against 2.38 at 20 s - the spurious information of the standard EKF
(plain ``ekf``'s ANEES on webmap is 3.1).  The current pose's covariance is its marginal
in the window's graph (``gtsam.Marginals``).  Lag 0 marginalises the previous pose at once (a
filter that relinearises the current step); a lag longer than the run re-solves the whole
graph at every epoch (the online optimum).  GTSAM's ``IncrementalFixedLagSmoother`` is not
used: on webmap with a 20 s lag its estimate ran away after the loop closure (34 m
position error at the end of a run whose batch-smoother twin ends at 0.2 m), and GTSAM's
maintainers call it known to have problems (borglab/gtsam pull request #1795).

Filter epochs without observations carry no pose variable; there the row predicts from
the previous filter epoch, :math:`T_s = T_p\,\Delta` with the body-frame covariance
:math:`\Sigma_s = \mathrm{Ad}_{\Delta^{-1}}\Sigma_p\mathrm{Ad}_{\Delta^{-1}}^\top +
\Sigma_\Delta` (the odometry factor's covariance, lateral σ and floor included), exactly
what the graph would give with a pose variable there and no new measurement.  Covariances
are returned in the world frame (:func:`~slam.kinds.planar.odometry.body_to_world_cov`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X
from numpy.typing import NDArray

from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.odometry import body_to_world_cov, relative_motions
from slam.kinds.planar.reference import (
    DEFAULT_LATERAL_SIGMA_M,
    SIGMA_FLOOR,
    PlanarReference,
    epoch_factors,
    graph_inputs,
    incremental,
    obs_noise_model,
    polish,
)
from slam.kinds.planar.world import ONLINE, fixed_lag_name
from slam.mapping.map_series import MapSeries
from slam.mapping.online_map import MapSampler

Array = NDArray[np.float64]

#: Relative-decrease stopping tolerance of the fixed-lag smoother's LM.
FLS_RELATIVE_TOL = 1e-8


@dataclass(frozen=True)
class OnlineTrack:
    """An online estimator's output on one log.

    poses (E, 3) and pose_cov (E, 3, 3, world frame) at the filter epochs; the final
    map: landmark_ids (L,), landmarks (L, 2), landmark_cov (L, 2, 2) or ``None``;
    time_s: wall time of the pass (updates, current estimates, marginals); map_series:
    the map's scores over time (the online row's, :mod:`slam.mapping.online_map`).
    """

    name: str
    poses: Array
    pose_cov: Array
    landmark_ids: NDArray[np.int64]
    landmarks: Array
    landmark_cov: Array | None
    time_s: float
    map_series: MapSeries | None = None


def at_filter_epochs(log: PlanarLog, graph_steps: NDArray[np.int64],
                     filter_steps: NDArray[np.int64], poses: Array, body_cov: Array,
                     lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M) -> tuple[Array, Array]:
    """Poses and world-frame covariances at ``filter_steps`` (a superset of
    ``graph_steps``) from the graph epochs' ``poses`` (Eg, 3) and body-frame ``body_cov``:
    filter epochs between graph epochs are predicted (module docstring)."""
    filter_steps = np.asarray(filter_steps, dtype=np.int64)
    index = np.searchsorted(filter_steps, graph_steps)
    if np.any(index >= len(filter_steps)) or np.any(filter_steps[index] != graph_steps):
        raise ValueError("the filter epochs must include every graph epoch")
    rel, rel_cov = relative_motions(log.controls, log.control_cov, log.dt, log.wheelbase,
                                    filter_steps)
    rel_cov = rel_cov + np.diag([SIGMA_FLOOR**2, lateral_sigma_m**2 + SIGMA_FLOOR**2,
                                 SIGMA_FLOOR**2])
    Ef = len(filter_steps)
    out_p, out_c = np.empty((Ef, 3)), np.empty((Ef, 3, 3))
    is_graph = np.zeros(Ef, bool)
    is_graph[index] = True
    out_p[index], out_c[index] = poses, body_cov
    for s in np.flatnonzero(~is_graph):  # s > 0: step 0 is a graph epoch
        delta = gtsam.Pose2(*rel[s - 1])
        pose = gtsam.Pose2(*out_p[s - 1]).compose(delta)
        ad = delta.inverse().AdjointMap()
        out_p[s] = (pose.x(), pose.y(), pose.theta())
        out_c[s] = ad @ out_c[s - 1] @ ad.T + rel_cov[s - 1]
    return out_p, body_to_world_cov(out_p[:, 2], out_c)


def final_map(estimate: gtsam.Values, cov_of, seen: set[int], with_cov: bool
              ) -> tuple[NDArray[np.int64], Array, Array | None]:
    ids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([estimate.atPoint2(L(int(j))) for j in ids], dtype=float).reshape(-1, 2)
    cov = (np.array([cov_of(L(int(j))) for j in ids], dtype=float).reshape(-1, 2, 2)
           if with_cov else None)
    return ids, lms, cov


def online_planar(log: PlanarLog, filter_steps: NDArray[np.int64], *,
                  lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M,
                  landmark_cov: bool = False) -> tuple[OnlineTrack, PlanarReference]:
    """The online row (iSAM2's :math:`x_{k|k}` and ``marginalCovariance(X(k))`` after every
    epoch) and the smoother polished from the same pass.

    The smoother's ``time_s`` leaves out the online row's per-epoch marginals (what the
    chunked path would not pay is still in it: the per-epoch updates); neither time holds
    the map's scoring (:class:`~slam.mapping.online_map.MapSampler`)."""
    t0 = time.perf_counter()
    g = graph_inputs(log, lateral_sigma_m)
    E = len(g.steps)
    poses, covs = np.empty((E, 3)), np.empty((E, 3, 3))
    spent = [0.0]
    sampler = MapSampler(log.landmarks, E)

    def record(e: int, k: int, isam: gtsam.ISAM2) -> None:
        t = time.perf_counter()
        p = isam.calculateEstimatePose2(X(k))
        poses[e] = (p.x(), p.y(), p.theta())
        covs[e] = isam.marginalCovariance(X(k))
        spent[0] += time.perf_counter() - t
        sampler.record(e, isam)

    graph, isam, seen = incremental(log, g, chunk=1, on_epoch=record)
    ids, lms, lm_cov = final_map(isam.calculateEstimate(), isam.marginalCovariance, seen,
                                 landmark_cov)
    p_f, c_f = at_filter_epochs(log, g.steps, filter_steps, poses, covs, lateral_sigma_m)
    t1 = time.perf_counter()
    track = OnlineTrack(ONLINE, p_f, c_f, ids, lms, lm_cov, t1 - t0 - sampler.seconds,
                        sampler.series(g.steps, filter_steps))
    ref = polish(graph, isam, seen, g.steps, True, t1)
    pass_s = t1 - t0 - spent[0] - sampler.seconds
    ref = replace(ref, time_solve_s=ref.time_solve_s + pass_s, time_s=ref.time_s + pass_s)
    return track, ref


def fixed_lag_planar(log: PlanarLog, filter_steps: NDArray[np.int64], lag_s: float, *,
                     lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M,
                     landmark_cov: bool = False,
                     on_epoch: Callable[[int, gtsam.BatchFixedLagSmoother, gtsam.Values,
                                         set[int]], None] | None = None) -> OnlineTrack:
    """The fixed-lag smoother of lag ``lag_s`` seconds over ``log``'s graph (module
    docstring): its current pose and marginal after every epoch, its map at the end;
    ``on_epoch(e, smoother, estimate, seen)`` is called after each epoch's update."""
    t0 = time.perf_counter()
    g = graph_inputs(log, lateral_sigma_m)
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(FLS_RELATIVE_TOL)
    smoother = gtsam.BatchFixedLagSmoother(float(lag_s), lm)
    E = len(g.steps)
    poses, covs = np.empty((E, 3)), np.empty((E, 3, 3))
    seen: set[int] = set()
    pose_est = gtsam.Pose2(*np.asarray(log.x0, dtype=float))
    by_step, obs_noise = log.observations_at(), obs_noise_model(log.obs_cov)
    for e in range(E):
        k = int(g.steps[e])
        new_f, new_v, pose_est = epoch_factors(log, g, e, pose_est, seen, by_step, obs_noise)
        stamps = gtsam.FixedLagSmootherKeyTimestampMap()
        t_k = k * log.dt
        stamps.insert((X(k), t_k))
        for j in seen:  # the map is never marginalised
            stamps.insert((L(j), t_k))
        smoother.update(new_f, new_v, stamps)
        estimate = smoother.calculateEstimate()
        pose_est = estimate.atPose2(X(k))
        poses[e] = (pose_est.x(), pose_est.y(), pose_est.theta())
        marginals = gtsam.Marginals(smoother.getFactors(), estimate)
        covs[e] = marginals.marginalCovariance(X(k))
        if on_epoch is not None:
            on_epoch(e, smoother, estimate, seen)
    ids, lms, lm_cov = final_map(estimate, marginals.marginalCovariance, seen, landmark_cov)
    p_f, c_f = at_filter_epochs(log, g.steps, filter_steps, poses, covs, lateral_sigma_m)
    return OnlineTrack(fixed_lag_name(lag_s), p_f, c_f, ids, lms, lm_cov,
                       time.perf_counter() - t0)
