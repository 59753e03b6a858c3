"""What a recorded-log run keeps for its report: every estimator's output as a
:class:`~slam.mapping.problem.SlamResult` (the filters' own; the smoother's and the
odometry's poses at every pose of the chain, without covariances).  A log is one run, so
these are kept whenever the campaign asks for tracks."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam.kinds.recorded.log import OdometryLog
from slam.kinds.recorded.models import dead_reckoning_poses
from slam.mapping.problem import SlamResult
from slam.results import ODOMETRY, REFERENCE


def _posed(name: str, poses: np.ndarray, ids: np.ndarray, landmarks: np.ndarray, time_s: float
           ) -> SlamResult:
    n = len(poses)
    return SlamResult(name, np.arange(n), poses, np.full((n, 3, 3), np.nan), ids, landmarks,
                      np.full((len(ids), 2, 2), np.nan), n - 1, nis=np.zeros(0),
                      nis_dof=np.zeros(0, int), time_s=time_s)


def log_tracks(log: OdometryLog, kept: dict[str, Any]) -> dict[str, SlamResult]:
    """The filters' results (``kept["results"]``), the online row (``kept["online"]``),
    the smoother's poses and map (``kept["reference"]``, if it did not fail) and the
    compounded odometry."""
    out = {**kept.get("results", {}), **kept.get("online", {})}
    ref = kept.get("reference")
    if ref is not None:
        out[REFERENCE] = _posed(REFERENCE, ref.poses, ref.landmark_ids, ref.landmarks,
                                ref.time_s)
    out[ODOMETRY] = _posed(ODOMETRY, dead_reckoning_poses(log), np.zeros(0, int),
                           np.zeros((0, 2)), 0.0)
    return out
