"""The drone log's sightings as GTSAM factors, built once per log: the noise of each
``BearingRangeFactor3D`` as :func:`slam.kinds.drone.reference.bearing_range_noise` gives
it, its math batched over the observations."""

from __future__ import annotations

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

from estimators.linalg import Array
from slam.kinds.drone.simulate import DroneLog


def sightings_factors(log: DroneLog, obs_cov: Array) -> tuple[list, Array]:
    """Every observation's ``BearingRangeFactor3D`` (noise as :func:`bearing_range_noise`,
    its math batched over the observations) and its body-frame landmark offset ``r u``
    (n, 3), built once for the keyframes' iSAM2 and the final graph."""
    z = np.asarray(log.obs, float).reshape(-1, 3)
    r, a, e = z.T
    ca, sa, ce, se = np.cos(a), np.sin(a), np.cos(e), np.sin(e)
    u = np.column_stack([ce * ca, ce * sa, se])
    J = np.empty((len(z), 3, 2))
    J[:, :, 0] = np.column_stack([-ce * sa, ce * ca, np.zeros(len(z))])
    J[:, :, 1] = np.column_stack([-se * ca, -se * sa, ce])
    units = [gtsam.Unit3(x) for x in u]
    Bs = np.array([x.basis() for x in units]).reshape(-1, 3, 2)
    M = np.swapaxes(Bs, -1, -2) @ J
    cov = np.zeros((len(z), 3, 3))
    cov[:, :2, :2] = M @ obs_cov[1:, 1:] @ np.swapaxes(M, -1, -2)
    cov[:, :2, 2] = M @ obs_cov[1:, 0]
    cov[:, 2, :2] = cov[:, :2, 2]
    cov[:, 2, 2] = obs_cov[0, 0]
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    ids, epochs = np.asarray(log.obs_id, np.int64), np.asarray(log.obs_epoch, np.int64)
    Cov = gtsam.noiseModel.Gaussian.Covariance
    factors = [gtsam.BearingRangeFactor3D(X(int(ep)), L(int(j)), unit, float(rng), Cov(c))
               for ep, j, unit, rng, c in zip(epochs, ids, units, r, cov)]
    return factors, r[:, None] * u


def add_sightings(log: DroneLog, sl: slice, pose, sightings: tuple[list, Array],
                   seen: set[int], graph, values) -> None:
    """The sightings ``sl`` of one epoch (:func:`sightings_factors`) added to ``graph``; a new
    landmark starts at its first sighting from ``pose``."""
    factors, offsets = sightings
    for i in range(sl.start, sl.stop):
        graph.add(factors[i])
        j = int(log.obs_id[i])
        if j not in seen:
            seen.add(j)
            values.insert(L(j), pose.transformFrom(offsets[i]))
