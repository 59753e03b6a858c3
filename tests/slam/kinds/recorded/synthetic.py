"""Test helper: random recorded logs in GTSAM's planar text format (not a test module)."""

from __future__ import annotations

import numpy as np

from slam.kinds.recorded.log import (
    OdometryLog,
)


def synthetic_log(rng: np.random.Generator, n_poses: int = 40, n_landmarks: int = 6
                  ) -> OdometryLog:
    """A random chain with id gaps, landmark ids interleaved with pose ids, sightings at
    the first pose and per-record covariances (non-diagonal ones too)."""
    ids, nxt, lm_ids = [], 3, []
    for _ in range(n_poses):
        ids.append(nxt)
        nxt += 1
        if rng.random() < 0.2 and len(lm_ids) < n_landmarks:
            lm_ids.append(nxt)
            nxt += 1
    while len(lm_ids) < n_landmarks:
        lm_ids.append(nxt)
        nxt += 1
    odo = np.column_stack([rng.uniform(0.2, 1.0, n_poses - 1), rng.normal(0, 0.01, n_poses - 1),
                           rng.normal(0, 0.05, n_poses - 1)])
    A = rng.normal(size=(n_poses - 1, 3, 3)) * [0.01, 0.003, 0.002]
    odo_cov = A @ np.swapaxes(A, 1, 2) + np.eye(3) * 1e-6
    obs_pose = np.sort(np.concatenate([[0, 0], rng.integers(0, n_poses, 30)]))
    obs_id = np.array(lm_ids)[rng.integers(0, n_landmarks, len(obs_pose))]
    obs = rng.normal(0, 8.0, (len(obs_pose), 2))
    B = rng.normal(size=(len(obs_pose), 2, 2)) * 0.3
    obs_cov = B @ np.swapaxes(B, 1, 2) + np.eye(2) * 0.05
    return OdometryLog(np.array(ids), odo, odo_cov, obs_pose, obs_id, obs, obs_cov, "syn")
