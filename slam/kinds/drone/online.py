r"""The drone's online optimum (row ``isam2``, ``[filters] online`` / ``--online``): iSAM2's
current state after every sensor epoch with its marginal covariance.

A filter's estimate at epoch :math:`k` uses the IMU samples and sightings up to :math:`k`;
the best an online Gaussian estimator can do there is the MAP estimate of the state at
:math:`k` given them, with its marginal covariance.  That is what iSAM2 holds after its
update with epoch :math:`k` over the smoother's graph (:mod:`slam.kinds.drone.reference`:
the same priors, ``CombinedImuFactor`` and ``BearingRangeFactor3D``), fed one epoch per
update (:func:`~slam.kinds.drone.reference._solve_isam` with ``feed = 1``), every interval
preintegrated about the prior bias - the smoother's default bias point - so the graph up
to :math:`k` is the log's alone and the row's last epoch is the final smoother's.  At each
epoch the row reads ``calculateEstimate`` of ``X(k)``, ``V(k)``, ``B(k)`` and
``marginalCovariance(X(k))`` (``Pose3`` ``[rotation, translation]``, body frame), taken to
the filters' ``[δp (world), δθ (body)]`` - the rows the drone's position and pose NEES are
computed on (:func:`slam.kinds.drone.scoring.score`).  The map is iSAM2's after the last
epoch.  The keyframes smoother stays the batch reference: this pass costs about one
iSAM2 update per epoch, which a re-sighted landmark makes re-factor most of the tree.

``time_s`` is the whole pass (preintegration, graph, updates, estimates and marginals read)
but the map's scoring over time (:mod:`slam.mapping.online_map`: iSAM2's landmark marginals
every tenth epoch, scored like a filter's map).
"""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, L, V, X

from nav.preintegration import pose3_world_cov
from nav.quaternion import dcm_to_q
from slam.kinds.drone.filtering import DroneEstimate
from slam.kinds.drone.reference import (
    StateRows,
    _prior_preintegrations,
    _solve_isam,
    preintegration_params,
)
from slam.kinds.drone.simulate import DroneLog
from slam.kinds.planar.world import ONLINE
from slam.mapping.online_map import MapSampler


def online_drone(log: DroneLog, *, imu_noise_scale: float = 1.0,
                 sensor_noise_scale: float = 1.0) -> DroneEstimate:
    """The online row on ``log`` (module docstring), with the filters' assumed noise
    scales."""
    t0 = time.perf_counter()
    E = log.n_epochs
    st, S = StateRows(E), np.empty((E, 6, 6))

    sampler = MapSampler(log.landmarks, E)

    def record(e: int, isam: gtsam.ISAM2) -> None:
        st.put(e, isam.calculateEstimatePose3(X(e)), isam.calculateEstimateVector(V(e)),
               isam.calculateEstimateConstantBias(B(e)))
        S[e] = isam.marginalCovariance(X(e))
        sampler.record(e, isam)

    params = preintegration_params(log, imu_noise_scale)
    _, values, seen = _solve_isam(log, params, log.obs_cov * sensor_noise_scale, 1,
                                  _prior_preintegrations(log, params), on_update=record)
    ids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([values.atPoint3(L(int(j))) for j in ids], dtype=float).reshape(-1, 3)
    return DroneEstimate(ONLINE, st.p, st.v, dcm_to_q(st.Rs), st.bias, pose3_world_cov(S, st.Rs),
                         ids, lms, np.full((len(ids), 3, 3), np.nan), nis=np.zeros(0),
                         nis_dof=np.zeros(0, int),
                         time_s=time.perf_counter() - t0 - sampler.seconds,
                         steps=E - 1, map_series=sampler.series(np.arange(E), np.arange(E)))
