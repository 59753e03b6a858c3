"""The GTSAM smoother of a recorded log: iSAM2 pose by pose, then a batch LM polish."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators.linalg import Array
from slam.kinds.recorded.log import PRIOR_SIGMA, OdometryLog

# --------------------------------------------------------------------------- the smoother


@dataclass(frozen=True)
class RecordedReference:
    """The smoother's estimate of a recorded log.

    poses : (P, 3) in chain order; landmark_ids (L,) ascending; landmarks (L, 2);
    objective / objective_isam2 : ``½χ²`` after the LM polish / after iSAM2;
    time_isam2_s, time_lm_s, time_s : wall times (iSAM2 includes building the graph);
    final_pose_cov : (3, 3) GTSAM's marginal covariance of the last pose (``Pose2`` local
    coordinates ``[x, y, θ]`` in the body frame) when asked for, else ``None``.
    """

    poses: Array
    landmark_ids: NDArray[np.int64]
    landmarks: Array
    objective: float
    objective_isam2: float
    time_isam2_s: float
    time_lm_s: float
    time_s: float
    final_pose_cov: Array | None = None


def bearing_range(z: Array, cov: Array) -> tuple[float, float, Array]:
    """``(bearing, range, covariance [b, r])`` of a robot-frame point, first order."""
    x, y = float(z[0]), float(z[1])
    r2 = x * x + y * y
    r = math.sqrt(r2)
    J = np.array([[-y / r2, x / r2], [x / r, y / r]])
    return math.atan2(y, x), r, J @ cov @ J.T


def smooth_recorded(log: OdometryLog, *, lm_iterations: int = 100,
                    final_marginal: bool = False,
                    on_pose: Callable[[int, Any, Any], None] | None = None
                    ) -> RecordedReference:
    """Smooth a recorded log with GTSAM: iSAM2 pose by pose, then a batch LM polish;
    with ``final_marginal`` also the last pose's marginal covariance (``gtsam.Marginals``).
    ``on_pose(k, key, isam)`` is called after iSAM2's update with pose ``k`` of the chain
    (``key`` its symbol); the online row reads iSAM2's current estimate there
    (:mod:`slam.kinds.recorded.online`)."""
    import gtsam
    from gtsam.symbol_shorthand import L, X

    t0 = time.perf_counter()
    noise_cache: dict[bytes, Any] = {}

    def noise(C: Array):
        key = C.tobytes()
        if key not in noise_cache:
            if not np.any(C - np.diag(np.diagonal(C))):
                noise_cache[key] = gtsam.noiseModel.Diagonal.Variances(np.diagonal(C).copy())
            else:
                noise_cache[key] = gtsam.noiseModel.Gaussian.Covariance(C)
        return noise_cache[key]

    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(0.1)
    params.relinearizeSkip = 1
    isam = gtsam.ISAM2(params)
    graph = gtsam.NonlinearFactorGraph()
    by_pose = log.observations_at()
    seen: set[int] = set()
    ids = log.pose_ids
    pose_est = gtsam.Pose2(0.0, 0.0, 0.0)
    for k in range(log.n_poses):
        new_f = gtsam.NonlinearFactorGraph()
        new_v = gtsam.Values()
        key = X(int(ids[k]))
        if k == 0:
            new_f.add(gtsam.PriorFactorPose2(key, pose_est,
                                             gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)))
        else:
            delta = gtsam.Pose2(*log.odometry[k - 1])
            new_f.add(gtsam.BetweenFactorPose2(X(int(ids[k - 1])), key, delta,
                                               noise(log.odometry_cov[k - 1])))
            pose_est = pose_est.compose(delta)
        new_v.insert(key, pose_est)
        sl = by_pose.get(k)
        if sl is not None:
            for lid, z, C in zip(log.obs_id[sl], log.obs[sl], log.obs_cov[sl]):
                b, r, Cbr = bearing_range(z, C)
                lid = int(lid)
                if abs(Cbr[0, 1]) > 0.0:
                    nm = gtsam.noiseModel.Gaussian.Covariance(Cbr)
                else:
                    nm = gtsam.noiseModel.Diagonal.Sigmas(np.sqrt(np.diagonal(Cbr)))
                new_f.add(gtsam.BearingRangeFactor2D(key, L(lid), gtsam.Rot2(b), r, nm))
                if lid not in seen:
                    seen.add(lid)
                    new_v.insert(L(lid), pose_est.transformFrom(np.asarray(z, dtype=float)))
        graph.push_back(new_f)
        isam.update(new_f, new_v)
        pose_est = isam.calculateEstimatePose2(key)
        if on_pose is not None:
            on_pose(k, key, isam)
    est = isam.calculateEstimate()
    t1 = time.perf_counter()
    obj_isam = float(graph.error(est))
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(1e-10)
    lm.setAbsoluteErrorTol(1e-12)
    lm.setMaxIterations(lm_iterations)
    values = gtsam.LevenbergMarquardtOptimizer(graph, est, lm).optimize()
    t2 = time.perf_counter()
    poses = np.array([[p.x(), p.y(), p.theta()]
                      for p in (values.atPose2(X(int(i))) for i in ids)]).reshape(-1, 3)
    lids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([values.atPoint2(L(int(j))) for j in lids], dtype=float).reshape(-1, 2)
    final_cov = (np.asarray(gtsam.Marginals(graph, values).marginalCovariance(X(int(ids[-1]))))
                 if final_marginal else None)
    return RecordedReference(poses, lids, lms, float(graph.error(values)), obj_isam,
                             t1 - t0, t2 - t1, t2 - t0, final_cov)


