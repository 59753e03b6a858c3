r"""The GTSAM reference of the ship: a batch AHRS smoother on the filters' own log.

Graph (keys at the vector epochs :math:`j = 0 \dots M-1`):

* ``Rot3`` attitude :math:`R_j = C(q_{nb})` and ``Vector3`` gyro drift :math:`\alpha_j`;
* ``AHRSFactor(R_j, R_{j+1}, α_j)`` from ``PreintegratedAhrsMeasurements`` of the
  interval's gyro samples, gyro covariance :math:`\sigma_{arw}^2 I` (the per-sample angle
  random walk), with the Earth rate as the parameters' ``omegaCoriolis``: the factor
  predicts :math:`R_i^\top R_j = \mathrm{Exp}(\theta(\alpha) - R_i^\top \omega_{ie}^n T)`,
  the first-order form of the filters' :math:`\mathrm{Exp}(-\omega_{ie}^n T) \otimes q
  \otimes \prod\mathrm{Exp}(\cdot)` (the two differ by the commutator
  :math:`\tfrac12[\theta, R_i^\top\omega_{ie}^n T]`, below 0.5″ per 1 s interval here);
* ``BetweenFactorVector(α_j, α_{j+1})``: the drift random walk, :math:`\sigma_{rw}\sqrt T`;
* one ``AttitudeFactorRot3(R_j; R_ref, B̄_j)`` per vector observation (gravity and the
  field direction), isotropic 2-D noise :math:`\sigma_j` (the tangent part of
  :math:`\mu_j \sim N(0, \sigma_j^2 I_3)` of a unit reference);
* priors on :math:`R_0, \alpha_0` equal to the filters' initial belief.

It starts from the filter-independent dead reckoning (the gyro alone, with the Earth rate,
from the filters' initial attitude and zero drift) and is solved by Levenberg-Marquardt.
Its marginals are body-frame (right perturbation), the filters' chart.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from nav.quaternion import dcm_to_q
from nav.strapdown import attitudes
from slam.kinds.ship.simulate import ShipLog
from slam.results import REFERENCE, EstimateSeries

Array = np.ndarray


def _rot(gtsam: Any, q: Array) -> Any:
    return gtsam.Rot3.Quaternion(*(float(c) for c in q))


def _priors(gtsam: Any, graph: Any, keys: tuple[int, int], x0: Array, P0: Array) -> None:
    att = gtsam.noiseModel.Gaussian.Covariance(np.asarray(P0[:3, :3], dtype=float))
    drift = gtsam.noiseModel.Gaussian.Covariance(np.asarray(P0[3:, 3:], dtype=float))
    graph.add(gtsam.PriorFactorRot3(keys[0], _rot(gtsam, x0[:4]), att))
    graph.add(gtsam.PriorFactorVector(keys[1], np.asarray(x0[4:], dtype=float), drift))


def _vector_factors(gtsam: Any, graph: Any, key: int, log: ShipLog, j: int) -> None:
    for ref, b, sigma in zip(log.refs, log.vectors[j], log.sigmas):
        noise = gtsam.noiseModel.Isotropic.Sigma(2, float(sigma))
        graph.add(gtsam.AttitudeFactorRot3(key, gtsam.Unit3(ref), noise, gtsam.Unit3(b)))


def _marginals(gtsam: Any, graph: Any, result: Any, X: list[int], B: list[int]) -> Array:
    covs = np.empty((len(X), 6, 6))
    marg = gtsam.Marginals(graph, result)
    for j, (x, b) in enumerate(zip(X, B)):
        jm = marg.jointMarginalCovariance([x, b])
        covs[j] = np.block([[jm.at(x, x), jm.at(x, b)], [jm.at(b, x), jm.at(b, b)]])
    return covs


def _ahrs_factors(gtsam: Any, graph: Any, log: ShipLog, keys: tuple[list, list],
                  arw: float, bias_rw: float) -> None:
    """One AHRS factor and one drift random-walk factor per vector interval."""
    X, B = keys
    params = gtsam.PreintegratedRotationParams()
    params.setGyroscopeCovariance(arw**2 * np.eye(3))
    params.setOmegaCoriolis(np.asarray(log.earth_rate, dtype=float))
    T = log.samples_per_update * log.dt
    walk = gtsam.noiseModel.Isotropic.Sigma(3, max(bias_rw * math.sqrt(T), 1e-15))
    for j in range(log.n_updates - 1):
        pim = gtsam.PreintegratedAhrsMeasurements(params, np.zeros(3))
        for w in log.gyro_block(j):
            pim.integrateMeasurement(w, log.dt)
        graph.add(gtsam.AHRSFactor(X[j], X[j + 1], B[j], pim))
        graph.add(gtsam.BetweenFactorVector(B[j], B[j + 1], np.zeros(3), walk))


def smooth_ship(log: ShipLog, x0: Array, P0: Array, arw: float, bias_rw: float,
                marginals: bool = True) -> EstimateSeries:
    """GTSAM batch smoother on ``log`` (module docstring).

    ``time_s`` covers building the graph (preintegration included) and the solve;
    ``extra_time_s`` the marginal covariances (NaN covariances without ``marginals``).
    """
    import gtsam

    t0 = time.perf_counter()
    M = log.n_updates
    X, B = ([gtsam.symbol(c, j) for j in range(M)] for c in "xb")
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    _priors(gtsam, graph, (X[0], B[0]), x0, P0)
    _ahrs_factors(gtsam, graph, log, (X, B), arw, bias_rw)
    dead_reckoned = attitudes(x0[:4], log.gyro, log.dt, log.earth_rate)[log.update_index]
    for j, (x, b, q) in enumerate(zip(X, B, dead_reckoned)):
        _vector_factors(gtsam, graph, x, log, j)
        values.insert(x, _rot(gtsam, q))
        values.insert(b, np.zeros(3))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-8)
    params.setAbsoluteErrorTol(1e-10)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    means = np.hstack([dcm_to_q(np.stack([result.atRot3(x).matrix() for x in X])),
                       np.stack([result.atVector(b) for b in B])])
    solve_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    covs = _marginals(gtsam, graph, result, X, B) if marginals else np.full((M, 6, 6), np.nan)
    return EstimateSeries(REFERENCE, means, covs, M - 1, nis=np.full(M, np.nan), nis_dof=0,
                          time_s=solve_s, extra_time_s=time.perf_counter() - t1)
