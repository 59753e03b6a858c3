r"""The batch yardstick for the fixed-wing INS/GNSS runs: a GTSAM factor-graph smoother.

Per epoch ``e`` of the INS filters (every GNSS fix; between fixes more than a second
apart, also at the epochs that cut the GNSS period: ``log.n_ins``) a ``Pose3`` ``X(e)``,
a velocity ``V(e)`` and an IMU bias ``B(e)``
(``imuBias.ConstantBias``, GTSAM's order ``[accelerometer, gyro]``), with

- priors on ``X(0)``, ``V(0)``, ``B(0)`` equal to the INS filters' initial belief (the
  rotation block in GTSAM's body-frame tangent, the position block rotated into the body
  frame, :math:`R^\top\Sigma R`; the bias prior's gyro σ combines the constant and the
  Markov drift σ);
- one ``CombinedImuFactor`` between consecutive epochs: the epoch's IMU samples
  preintegrated with the densities the filters assume (white noise; the Markov drifts'
  driving densities as GTSAM's bias random walk - over an epoch of 1 s and correlation
  times of minutes the two agree; GTSAM has no first-order Markov bias), ENU gravity
  (``MakeSharedU``), ``setOmegaCoriolis`` when the world has Earth rate;
- a ``GPSFactor`` per fix (position, σ horizontal/vertical) and a ``PriorFactorVector``
  on ``V(e)`` for the GNSS velocity (the "prior on the velocity key" reading), at the
  epochs of the fixes.

Solving as for the drone (:mod:`slam.kinds.drone.reference`): iSAM2 fed in batches, each
new state predicted from the current estimate by the preintegrated measurement (dead
reckoning from the smoother's own estimate, independent of the filters), then a
Levenberg-Marquardt polish.  Marginals: the joint ``[X(e), V(e)]`` covariance converted to
the filters' ``[δp (world), δv, δθ (body)]`` with :math:`\delta p = R\,\delta t`.
"""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from nav.preintegration import combined_params
from nav.quaternion import dcm_to_q
from slam.failures import reason
from slam.kinds.fixed_wing.simulate import FixedWingLog

Array = np.ndarray
ISAM_BATCH = 10


def _rot(q: Array) -> gtsam.Rot3:
    return gtsam.Rot3.Quaternion(float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def params(log: FixedWingLog) -> gtsam.PreintegrationCombinedParams:
    """Combined-IMU preintegration parameters (module docstring)."""
    imu = log.world.imu
    return combined_params(float(-log.gravity[2]), imu.gyro_arw_rad_sqrt_s**2,
                           imu.accel_vrw_mps_sqrt_s**2, imu.gyro_drift_rw_rad_s_sqrt_s**2,
                           imu.accel_drift_rw_mps2_sqrt_s**2, earth_rate=log.earth_rate)


def _priors(x0: Array, P0: Array) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    R0 = _rot(x0[6:10])
    Rm = R0.matrix()
    pose_cov = np.zeros((6, 6))
    pose_cov[:3, :3] = P0[6:9, 6:9]
    pose_cov[3:, 3:] = Rm.T @ P0[0:3, 0:3] @ Rm
    d = np.diag(P0)
    bias_sig = np.sqrt(np.concatenate([d[15:18], d[9:12] + d[12:15]]))
    pose0, vel0 = gtsam.Pose3(R0, np.asarray(x0[0:3], float)), np.asarray(x0[3:6], float)
    bias0 = gtsam.imuBias.ConstantBias(np.zeros(3), np.zeros(3))
    g = gtsam.NonlinearFactorGraph()
    g.add(gtsam.PriorFactorPose3(X(0), pose0, gtsam.noiseModel.Gaussian.Covariance(pose_cov)))
    g.add(gtsam.PriorFactorVector(V(0), vel0, gtsam.noiseModel.Gaussian.Covariance(P0[3:6, 3:6])))
    g.add(gtsam.PriorFactorConstantBias(B(0), bias0, gtsam.noiseModel.Diagonal.Sigmas(bias_sig)))
    vals = gtsam.Values()
    vals.insert(X(0), pose0)
    vals.insert(V(0), vel0)
    vals.insert(B(0), bias0)
    return g, vals


def _gnss_factors(log: FixedWingLog, e: int, graph: gtsam.NonlinearFactorGraph) -> None:
    """The fix of epoch ``e`` (none between fixes)."""
    if e % log.fix_every:
        return
    i = e // log.fix_every
    gn = log.world.gnss
    pos_noise = gtsam.noiseModel.Diagonal.Sigmas(
        np.array([gn.horizontal_sigma_m, gn.horizontal_sigma_m, gn.vertical_sigma_m]))
    vel_noise = gtsam.noiseModel.Isotropic.Sigma(3, gn.velocity_sigma_mps)
    graph.add(gtsam.GPSFactor(X(e), np.asarray(log.gnss_p[i], float), pos_noise))
    graph.add(gtsam.PriorFactorVector(V(e), np.asarray(log.gnss_v[i], float), vel_noise))


def _solve(log: FixedWingLog, x0: Array, P0: Array
           ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    """iSAM2 in batches of ``ISAM_BATCH`` epochs, then an LM polish (module docstring)."""
    prm = params(log)
    graph, vals = _priors(x0, P0)
    _gnss_factors(log, 0, graph)
    isam_params = gtsam.ISAM2Params()
    isam_params.setFactorization("QR")
    isam = gtsam.ISAM2(isam_params)
    isam.update(graph, vals)
    state = (vals.atPose3(X(0)), vals.atVector(V(0)), vals.atConstantBias(B(0)))
    n, G = log.n_ins, log.ins_epochs
    new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for e in range(1, G):
        pim = gtsam.PreintegratedCombinedMeasurements(prm, state[2])
        for acc, gyr in zip(log.accel[(e - 1) * n:e * n], log.gyro[(e - 1) * n:e * n]):
            pim.integrateMeasurement(acc, gyr, log.dt)
        new_f.add(gtsam.CombinedImuFactor(X(e - 1), V(e - 1), X(e), V(e), B(e - 1), B(e), pim))
        _gnss_factors(log, e, new_f)
        pred = pim.predict(gtsam.NavState(state[0], state[1]), state[2])
        state = (pred.pose(), pred.velocity(), state[2])
        new_v.insert(X(e), state[0])
        new_v.insert(V(e), state[1])
        new_v.insert(B(e), state[2])
        if e % ISAM_BATCH and e < G - 1:
            continue
        graph.push_back(new_f)
        isam.update(new_f, new_v)
        new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        state = (isam.calculateEstimatePose3(X(e)), isam.calculateEstimateVector(V(e)),
                 isam.calculateEstimateConstantBias(B(e)))
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(1e-10)
    lm.setAbsoluteErrorTol(1e-12)
    lm.setMaxIterations(50)
    return graph, gtsam.LevenbergMarquardtOptimizer(graph, isam.calculateEstimate(), lm).optimize()


def smooth(log: FixedWingLog, x0: Array, P0: Array
           ) -> tuple[Array, Array, float, str | None]:
    """``(means (G, 19), covs (G, 9, 9), solve time, note)``: the smoothed INS states at the
    INS filters' epochs (drifts: GTSAM's bias, gyro as the constant part) and their
    ``[δp, δv, δθ]`` marginals; when GTSAM cannot factor the marginals (measured: fixes
    100 s apart with 1 s states) the covariances are NaN and ``note`` says why (counted in
    the summary as ``no_covariance_runs``), the estimate is kept."""
    t0 = time.perf_counter()
    graph, values = _solve(log, x0, P0)
    solve_s = time.perf_counter() - t0
    G = log.ins_epochs
    means, covs = np.zeros((G, 19)), np.full((G, 9, 9), np.nan)
    try:
        marg, note = gtsam.Marginals(graph, values), None
    except RuntimeError as exc:
        marg, note = None, f"marginals: {reason(exc)}"
    for e in range(G):
        pose = values.atPose3(X(e))
        R = pose.rotation().matrix()
        bias = values.atConstantBias(B(e)).vector()
        means[e] = np.concatenate([pose.translation(), values.atVector(V(e)), dcm_to_q(R),
                                   bias[3:], np.zeros(3), bias[:3]])
        if marg is None:
            continue
        S = marg.jointMarginalCovariance([X(e), V(e)]).fullMatrix()  # [rot, trans, vel]
        T = np.zeros((9, 9))
        T[0:3, 3:6], T[3:6, 6:9], T[6:9, 0:3] = R, np.eye(3), np.eye(3)
        covs[e] = T @ S @ T.T
    return means, covs, solve_s, note
