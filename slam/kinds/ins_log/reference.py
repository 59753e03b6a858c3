r"""The GTSAM IMU + GPS smoother on an IMU + GNSS log, online and smoothed.

Per fix epoch ``e`` (from the alignment fix ``a``) a ``Pose3`` ``X(e)``, velocity ``V(e)``
and bias ``B(e)`` (GTSAM's order ``[accelerometer, gyro]``), with

- priors on ``X(a), V(a), B(a)`` equal to the filters' prior (the rotation block in GTSAM's
  body tangent, the position block :math:`R^\top\Sigma_pR`);
- a ``CombinedImuFactor`` per epoch: the epoch's IMU pieces (the same cut readings and
  intervals the filters mechanise) preintegrated with the log's white-noise densities and
  bias random-walk PSDs (:meth:`nav.imu_noise.BiasProcess.psd`; GTSAM has no Markov bias,
  so a Markov part enters as its driving PSD), gravity ``MakeSharedU`` of the log's
  normal gravity, ``setOmegaCoriolis`` with Earth rate;
- a ``GPSFactor`` (``GPSFactorArm`` with a lever arm) at every used fix and a
  ``PriorFactorVector`` on ``V(e)`` for a GNSS velocity.

iSAM2 is updated at every fix, each new state predicted from the current estimate by the
preintegrated measurement (GTSAM's ``IMUKittiExampleGPS.py`` logic, with the aligned
rotation prior in place of its zero-precision one).  ``gtsam-online`` is the estimate of
``X(e)`` right after the update at ``e`` (what a filter would output); the smoothed
estimate (the reference) is iSAM2's final estimate after two more relinearising updates.
Position covariances come from the marginals at the fixes that are scored (timed); the
smoothed estimate's pose covariance at every other fix is taken after the timing, for the
TUM sidecar (``gtsam-online`` has it at the scored fixes only: later marginals are not
that epoch's).
"""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from nav.preintegration import combined_params, pose3_world_cov
from slam.failures import reason
from slam.kinds.ins_log.log import InsLog
from slam.kinds.ins_log.run import ONLINE, POSE, SMOOTHED, USED, WITHHELD, EstimatorTrack, model_of

Array = np.ndarray
REFERENCE_FAILURES = (RuntimeError, ValueError)


def _rot(q: Array) -> gtsam.Rot3:
    return gtsam.Rot3.Quaternion(float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def _priors(x0: Array, P0: Array, a: int) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    R0 = _rot(x0[6:10])
    Rm = R0.matrix()
    pose_cov = np.zeros((6, 6))
    pose_cov[:3, :3] = P0[6:9, 6:9]
    pose_cov[3:, 3:] = Rm.T @ P0[0:3, 0:3] @ Rm
    bias_sig = np.sqrt(np.concatenate([np.diag(P0)[12:15], np.diag(P0)[9:12]]))
    pose0, vel0 = gtsam.Pose3(R0, np.asarray(x0[0:3], float)), np.asarray(x0[3:6], float)
    bias0 = gtsam.imuBias.ConstantBias(np.zeros(3), np.zeros(3))
    g = gtsam.NonlinearFactorGraph()
    g.add(gtsam.PriorFactorPose3(X(a), pose0, gtsam.noiseModel.Gaussian.Covariance(pose_cov)))
    g.add(gtsam.PriorFactorVector(V(a), vel0, gtsam.noiseModel.Gaussian.Covariance(P0[3:6, 3:6])))
    g.add(gtsam.PriorFactorConstantBias(B(a), bias0, gtsam.noiseModel.Diagonal.Sigmas(bias_sig)))
    vals = gtsam.Values()
    vals.insert(X(a), pose0)
    vals.insert(V(a), vel0)
    vals.insert(B(a), bias0)
    return g, vals


def _gnss(log: InsLog, i: int, graph: gtsam.NonlinearFactorGraph) -> None:
    arm = np.asarray(log.settings.lever_arm_m, float)
    if log.fix_p is not None:
        noise = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(log.fix_sp[i], float))
        z = np.asarray(log.fix_p[i], float)
        graph.add(gtsam.GPSFactorArm(X(i), z, arm, noise) if np.any(arm)
                  else gtsam.GPSFactor(X(i), z, noise))
    if log.fix_v is not None:
        graph.add(gtsam.PriorFactorVector(V(i), np.asarray(log.fix_v[i], float),
                                          gtsam.noiseModel.Diagonal.Sigmas(
                                              np.asarray(log.fix_sv[i], float))))


def _pose_cov(isam: gtsam.ISAM2, pose: gtsam.Pose3, key: int) -> Array:
    """iSAM2's marginal of ``key`` as the filters' ``[δp (navigation frame), δθ (body)]``
    covariance (:func:`nav.preintegration.pose3_world_cov`)."""
    return pose3_world_cov(isam.marginalCovariance(key)[None],
                           pose.rotation().matrix()[None])[0]


def _quat(pose: gtsam.Pose3) -> Array:
    q = pose.rotation().toQuaternion()
    return np.array([q.w(), q.x(), q.y(), q.z()])


def _run(log: InsLog, a: int, x0: Array, P0: Array, roles: Array
         ) -> tuple[EstimatorTrack, EstimatorTrack]:
    c0 = time.process_time()
    model = model_of(log)
    psd = log.settings.psd
    prm = combined_params(float(-model.gravity[2]), psd.gyro_density**2, psd.accel_density**2,
                          psd.gyro_bias.psd(), psd.accel_bias.psd(), earth_rate=model.earth_rate)
    graph, vals = _priors(x0, P0, a)
    params = gtsam.ISAM2Params()
    isam = gtsam.ISAM2(params)
    isam.update(graph, vals)
    F = log.n_fixes
    E = F - a
    arm = np.asarray(log.settings.lever_arm_m, float)
    p_on, C_on = np.full((E, 3), np.nan), np.full((E, 6, 6), np.nan)
    f_on, f_sm = np.full((E, 3), np.nan), np.full((E, 3), np.nan)
    q_on, q_sm = np.full((E, 4), np.nan), np.full((E, 4), np.nan)
    p_on[0], C_on[0], q_on[0] = x0[0:3], P0[POSE][:, POSE], x0[6:10]
    f_on[0] = vals.atPose3(X(a)).transformFrom(arm)
    state = (vals.atPose3(X(a)), vals.atVector(V(a)), vals.atConstantBias(B(a)))
    scored = roles != USED
    for i in range(a + 1, F):
        g, f, h = log.epochs.of(i)
        pim = gtsam.PreintegratedCombinedMeasurements(prm, state[2])
        for k in range(len(h)):
            pim.integrateMeasurement(f[k], g[k], float(h[k]))
        nf, nv = gtsam.NonlinearFactorGraph(), gtsam.Values()
        nf.add(gtsam.CombinedImuFactor(X(i - 1), V(i - 1), X(i), V(i), B(i - 1), B(i), pim))
        if roles[i] == USED:
            _gnss(log, i, nf)
        pred = pim.predict(gtsam.NavState(state[0], state[1]), state[2])
        nv.insert(X(i), pred.pose())
        nv.insert(V(i), pred.velocity())
        nv.insert(B(i), state[2])
        isam.update(nf, nv)
        pose = isam.calculateEstimatePose3(X(i))
        state = (pose, isam.calculateEstimateVector(V(i)), isam.calculateEstimateConstantBias(B(i)))
        p_on[i - a], q_on[i - a] = pose.translation(), _quat(pose)
        f_on[i - a] = pose.transformFrom(arm)
        if scored[i]:
            C_on[i - a] = _pose_cov(isam, pose, X(i))
    online_s = time.process_time() - c0
    for _ in range(2):
        isam.update()
    est = isam.calculateEstimate()
    p_sm, C_sm = np.full((E, 3), np.nan), np.full((E, 6, 6), np.nan)
    poses = [est.atPose3(X(i)) for i in range(a, F)]
    for e, pose in enumerate(poses):
        p_sm[e], q_sm[e] = pose.translation(), _quat(pose)
        f_sm[e] = pose.transformFrom(arm)
        if scored[a + e]:
            C_sm[e] = _pose_cov(isam, pose, X(a + e))
    smooth_s = time.process_time() - c0
    for e, pose in enumerate(poses):  # the TUM sidecar's other rows, outside the timing
        if not scored[a + e]:
            C_sm[e] = _pose_cov(isam, pose, X(a + e))
    empty = np.zeros(0)
    return (EstimatorTrack(ONLINE, p_on, C_on[:, :3, :3], empty, empty.astype(np.int64), 3,
                           online_s, None, f_on, q_on, C_on),
            EstimatorTrack(SMOOTHED, p_sm, C_sm[:, :3, :3], empty, empty.astype(np.int64), 3,
                           smooth_s, None, f_sm, q_sm, C_sm))


def smooth(log: InsLog, a: int, x0: Array, P0: Array, roles: Array
           ) -> dict[str, EstimatorTrack]:
    """``{gtsam-online: ..., gtsam: ...}`` (module docstring); a numerical failure of GTSAM
    is both estimators' counted failure with its reason."""
    try:
        on, sm = _run(log, a, x0, P0, roles)
    except REFERENCE_FAILURES as exc:
        E = log.n_fixes - a
        nan = np.full((E, 3), np.nan)
        why = reason(exc)
        mk = (lambda n: EstimatorTrack(n, nan, np.full((E, 3, 3), np.nan), np.zeros(0),  # noqa: E731
                                       np.zeros(0, np.int64), 3, 0.0, why))
        return {ONLINE: mk(ONLINE), SMOOTHED: mk(SMOOTHED)}
    return {ONLINE: on, SMOOTHED: sm}


__all__ = ["smooth", "WITHHELD"]
