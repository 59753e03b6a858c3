r"""The online optimum of a recorded log (row ``isam2``): iSAM2's current pose after every
filter epoch, from the smoother's own pass.

A filter's estimate at epoch :math:`k` uses the records up to pose :math:`k`; the best an
online Gaussian estimator can do there is the MAP estimate of pose :math:`k` given them,
:math:`\hat T_{k|k}`, with its marginal covariance - what iSAM2 holds after its update with
pose :math:`k` in :func:`~slam.kinds.recorded.reference.smooth_recorded` (the log's own
between and bearing-range factors, fed one pose at a time).  The row is read there
(``calculateEstimatePose2`` and ``marginalCovariance`` at the filter epochs,
:func:`~slam.kinds.recorded.models.recorded_epochs`), so it costs one pass with the
smoother; its map is iSAM2's after the last pose.  The planar kind's
:func:`~slam.kinds.planar.online.online_planar` does the same over the graph it builds
from controls; a log brings its own graph, so the smoother's loop is reused instead.

``Pose2`` marginals are body-frame ``[x, y, θ]`` (right perturbation); they are returned
in the world frame of the filters' ``pose_cov``
(:func:`~slam.kinds.planar.odometry.body_to_world_cov`).  The row's ``time_s`` is the
whole iSAM2 pass (building the graph, the updates, the estimates and marginals read);
the smoother from the same pass keeps its own times without those reads.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slam.kinds.planar.odometry import body_to_world_cov
from slam.kinds.planar.world import ONLINE
from slam.kinds.recorded.log import OdometryLog
from slam.kinds.recorded.reference import RecordedReference, smooth_recorded
from slam.mapping.problem import SlamResult


def online_recorded(log: OdometryLog, steps: NDArray[np.int64], *,
                    final_marginal: bool = False) -> tuple[SlamResult, RecordedReference]:
    """The online row at the filter epochs ``steps`` (chain indices, ascending) and the
    smoother polished from the same pass (``final_marginal`` as
    :func:`~slam.kinds.recorded.reference.smooth_recorded`)."""
    from gtsam.symbol_shorthand import L

    steps = np.asarray(steps, dtype=np.int64)
    at = {int(k): e for e, k in enumerate(steps)}
    E = len(steps)
    poses, cov = np.full((E, 3), np.nan), np.full((E, 3, 3), np.nan)
    spent = [0.0]
    state: dict[str, Any] = {}

    def record(k: int, key: Any, isam: Any) -> None:
        e = at.get(k)
        if e is None:
            return
        t = time.perf_counter()
        p = isam.calculateEstimatePose2(key)
        poses[e] = (p.x(), p.y(), p.theta())
        cov[e] = isam.marginalCovariance(key)
        state["isam"] = isam
        spent[0] += time.perf_counter() - t

    ref = smooth_recorded(log, final_marginal=final_marginal, on_pose=record)
    t = time.perf_counter()
    est = state["isam"].calculateEstimate()
    lms = np.array([est.atPoint2(L(int(j))) for j in ref.landmark_ids],
                   dtype=float).reshape(-1, 2)
    final_read = time.perf_counter() - t
    row = SlamResult(ONLINE, steps, poses, body_to_world_cov(poses[:, 2], cov),
                     ref.landmark_ids.copy(), lms, np.full((len(lms), 2, 2), np.nan), E - 1,
                     nis=np.zeros(0), nis_dof=np.zeros(0, int),
                     time_s=ref.time_isam2_s + final_read)
    ref = replace(ref, time_isam2_s=ref.time_isam2_s - spent[0],
                  time_s=ref.time_s - spent[0])
    return row, ref
