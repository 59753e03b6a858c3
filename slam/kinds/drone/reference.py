r"""The batch-optimal yardstick for drone SINS/SLAM logs: a GTSAM factor-graph smoother.

:func:`smooth_drone` runs over the very measurements the filters see in a
:class:`~slam.kinds.drone.simulate.DroneLog` and returns the MAP estimate at every sensor
epoch with marginal covariances.  The graph has, per epoch ``e``, a ``Pose3`` ``X(e)``,
a velocity ``V(e)`` and an IMU bias ``B(e)`` (``imuBias.ConstantBias``, GTSAM's order
``[accelerometer, gyro]``), and a ``Point3`` ``L(j)`` per observed landmark, with

- priors on ``X(0)``, ``V(0)``, ``B(0)`` equal to the filters' initial belief: the
  log's ``x0`` and ``P0`` (position block taken into the body-frame translation tangent
  of ``Pose3`` with :math:`R^\top \Sigma R`; a standard-deviation floor of ``1e-4`` (m,
  m/s, rad) keeps a zero ``P0`` block a stiff prior rather than a hard constraint);
- one ``CombinedImuFactor`` between consecutive epochs: the epoch's IMU samples
  preintegrated by ``PreintegratedCombinedMeasurements`` with the densities the filters
  assume (gyro / accelerometer white noise, bias random walks; ENU gravity
  ``MakeSharedU``; ``setOmegaCoriolis`` when the log has Earth rate), so the bias
  random walk between epochs is part of the factor, as in the filters' process noise;
- one ``BearingRangeFactor3D`` per observation: the body-frame bearing as a ``Unit3``
  and the range; the (azimuth, elevation) covariance is mapped into the ``Unit3``
  tangent at the measured direction, :math:`B^\top J\,\mathrm{diag}(\sigma_a^2,
  \sigma_e^2)\,J^\top B` with :math:`J = \partial u/\partial(a, e)` and :math:`B` the
  measured direction's ``basis()`` (the factor's error is
  ``measured.localCoordinates(predicted)`` to first order).

Solving (:func:`solve_graph`): the epochs are fed to iSAM2 (each new state predicted from
the previous one by the preintegrated measurement, starting from iSAM2's current estimate
at each update; each new landmark initialised by inverting its first observation), then
a batch Levenberg-Marquardt polish (relative tolerance per schedule, :data:`LM_REL_TOL`).
Two schedules and two preintegration bias points:

- ``schedule="epochs"``: ``ISAM_BATCH`` epochs per update (iSAM2's estimate along the
  way is the online one); ``"keyframes"``: iSAM2 only initialises the final solve, on
  every ``KEYFRAME``-th epoch (one IMU factor per keyframe interval, the keyframes'
  sightings; ``KEYFRAME_FEED`` keyframes per update), the epochs between predicted from
  the keyframe before them.  A landmark seen again re-factors most of the Bayes tree at
  every update, so the keyframes' ten times smaller tree is what makes it cheap; the
  final solve is the same graph, so it reaches the same optimum;
- ``bias_point="estimate"``: each interval preintegrated about iSAM2's bias estimate at
  the start of its update, so the graph, and its optimum, depend on the schedule (a
  change of ``ISAM_BATCH`` moves the optimum's errors by ~1e-5 relative: the first-order
  bias correction of the preintegrated measurements is not exact); ``"prior"``: every
  interval preintegrated once, about the prior bias, so the graph is the log's alone
  and every schedule reaches the same optimum (the correction's error is second order
  in the bias change over an epoch, :math:`(\delta b_g\,\Delta t)^2 \sim 10^{-9}`).

The old reference (``"epochs"``, ``"estimate"``, ``"joint"`` marginals) is the benchmark's
``today``; the defaults (``"keyframes"``, ``"prior"``, ``"chain"``) cost about a third of
it (``python -m benchmarks.smoother_speed_nav``; docs/performance.md) at the optimum of
their own graph, whose bias points differ, so their scores differ from the old path's by up
to ~1e-4 relative.

iSAM2 factorises by QR: with Cholesky it declares the graph indeterminate within the
first landmark sightings (information spans ~1e14 from the bias random walk to the
landmarks), which QR solves without complaint.
Marginals (``marginal_method``): ``"chain"`` (default) once by the square-root sweep of
:mod:`slam.chain_marginals` (epoch columns ``[X, V, B]``, the landmarks global), or
``"joint"`` by GTSAM's ``Marginals`` (the old default).  On the first 40 epochs of the
small test world the chain equals a dense QR inverse to 8e-12 of
:math:`\sqrt{\Sigma_{ii}\Sigma_{kk}}`, GTSAM's to 1e-7, so the switch moved the
smoother's ANEES by ~1e-8.
``Pose3`` covariances are ``[rotation, translation]`` in the body frame
(right perturbation); they are converted to the filters' ``[δp (world), δθ (body)]``
with :math:`\delta p = R\,\delta t`.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, L, V, X

from estimators.linalg import Array
from nav.preintegration import combined_params, pose3_world_cov
from nav.quaternion import dcm_to_q
from slam.chain_marginals import chain_marginals, jacobian_rows
from slam.kinds.drone.filtering import DroneEstimate
from slam.kinds.drone.sightings import add_sightings, sightings_factors
from slam.kinds.drone.simulate import DroneLog
from slam.results import REFERENCE

#: Standard-deviation floor of the priors (m, m/s, rad, bias units).
SIGMA_FLOOR = 1e-4
#: iSAM2 relinearisation: check every RELIN_SKIP updates, threshold RELIN_THRESHOLD
#: (rad, m); the final Levenberg-Marquardt polish relinearises everything anyway.
RELIN_SKIP = 10
RELIN_THRESHOLD = 0.1
#: Epochs handed to iSAM2 per update (1 s at 5 Hz); within a batch each new state is
#: predicted from the previous one by the preintegrated measurements.
ISAM_BATCH = 5
#: The ``"keyframes"`` schedule: every KEYFRAME-th epoch is a keyframe (2 s at 5 Hz);
#: iSAM2 gets KEYFRAME_FEED keyframes per update.  One per update: with ten (20 s of
#: dead reckoning per update) iSAM2's estimate on ``drone-large-yaw`` run 0 was so far off
#: that the final LM stopped in a wrong minimum (73 m position RMSE, 1/2 chi^2 1.26e6
#: against the epochs schedule's 1643, measured), and one per update costs no more on
#: drone and drone-hills.
KEYFRAME = 10
KEYFRAME_FEED = 1
#: Schedules and preintegration bias points of :func:`solve_graph`, and the defaults.
SCHEDULES = ("epochs", "keyframes")
BIAS_POINTS = ("estimate", "prior")
SCHEDULE = "keyframes"
BIAS_POINT = "prior"
#: The final LM's relative tolerance per schedule (absolute 1e-12).  From the keyframes'
#: start LM's third step changes ½χ² by 1.3e-10 (drone), 5.4e-10 (drone-large-yaw),
#: 9.6e-11 (drone-hills), the fourth by < 3e-13: at 1e-9 it stops after the third
#: (measured against 1e-10 on run 0: ½χ² 2.7e-13 relative, positions 3e-8 m, marginals
#: 3e-9 of sigma apart).  The epochs schedule (the old reference) keeps 1e-10.
LM_REL_TOL = {"epochs": 1e-10, "keyframes": 1e-9}
#: The marginals' methods (:func:`_marginals`) and the default.
MARGINAL_METHODS = ("joint", "chain")
MARGINAL_METHOD = "chain"


def _rot(q: Array) -> gtsam.Rot3:
    return gtsam.Rot3.Quaternion(float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def _bias(x: Array) -> gtsam.imuBias.ConstantBias:
    """ConstantBias from a state's ``[b_g, b_a]`` (GTSAM stores ``[acc, gyro]``)."""
    return gtsam.imuBias.ConstantBias(np.asarray(x[13:16], float), np.asarray(x[10:13], float))


def preintegration_params(log: DroneLog, imu_noise_scale: float = 1.0
                          ) -> gtsam.PreintegrationCombinedParams:
    """Combined-IMU preintegration parameters of the log (densities the filters assume)."""
    n = log.imu_noise.scaled(imu_noise_scale)
    rate = log.nav.earth_rate
    return combined_params(float(-log.nav.gravity[2]), n.gyro_arw**2, n.accel_vrw**2,
                           n.gyro_bias_rw**2, n.accel_bias_rw**2,
                           earth_rate=rate if rate is not None and np.any(rate) else None)


def bearing_range_noise(z: Array, obs_cov: Array) -> gtsam.noiseModel.Base:
    """Noise of a ``BearingRangeFactor3D`` for ``z = [r, az, el]`` (module docstring)."""
    _, a, e = z
    u = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    J = np.column_stack([[-np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), 0.0],
                         [-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)]])
    Bs = gtsam.Unit3(u).basis()
    M = Bs.T @ J
    cov = np.zeros((3, 3))
    cov[:2, :2] = M @ obs_cov[1:, 1:] @ M.T
    cov[:2, 2] = M @ obs_cov[1:, 0]
    cov[2, :2] = cov[:2, 2]
    cov[2, 2] = obs_cov[0, 0]
    return gtsam.noiseModel.Gaussian.Covariance(0.5 * (cov + cov.T))


def _prior_factors(log: DroneLog) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    """Priors on the first pose, velocity and bias equal to the filters' initial belief
    (body-frame rotation first in GTSAM's Pose3 tangent), with the values they anchor."""
    x0, P0 = log.x0, log.P0
    R0 = _rot(x0[6:10])
    floor = SIGMA_FLOOR**2 * np.eye(3)
    Rm = R0.matrix()
    pose_cov = np.zeros((6, 6))
    pose_cov[:3, :3] = P0[6:9, 6:9] + floor
    pose_cov[3:, 3:] = Rm.T @ P0[0:3, 0:3] @ Rm + floor
    bias_sig = np.sqrt(np.concatenate([np.diag(P0)[12:15], np.diag(P0)[9:12]]) + SIGMA_FLOOR**2)
    pose0 = gtsam.Pose3(R0, np.asarray(x0[0:3], float))
    vel0 = np.asarray(x0[3:6], float)
    first = gtsam.NonlinearFactorGraph()
    first.add(gtsam.PriorFactorPose3(X(0), pose0, gtsam.noiseModel.Gaussian.Covariance(pose_cov)))
    first.add(gtsam.PriorFactorVector(V(0), vel0,
                                      gtsam.noiseModel.Gaussian.Covariance(P0[3:6, 3:6] + floor)))
    first.add(gtsam.PriorFactorConstantBias(B(0), _bias(x0),
                                            gtsam.noiseModel.Diagonal.Sigmas(bias_sig)))
    vals = gtsam.Values()
    vals.insert(X(0), pose0)
    vals.insert(V(0), vel0)
    vals.insert(B(0), _bias(x0))
    return first, vals


def _landmark_factors(log: DroneLog, e: int, sl: slice, pose_e, obs_cov: Array, seen: set[int],
                      new_f, new_v) -> None:
    """``BearingRangeFactor3D`` per sighting of epoch ``e``; a new landmark starts at its
    first sighting."""
    for j, z in zip(log.obs_id[sl], log.obs[sl]):
        j = int(j)
        r, a, el = z
        u = np.array([np.cos(el) * np.cos(a), np.cos(el) * np.sin(a), np.sin(el)])
        new_f.add(gtsam.BearingRangeFactor3D(X(e), L(j), gtsam.Unit3(u), float(r),
                                             bearing_range_noise(z, obs_cov)))
        if j not in seen:
            seen.add(j)
            new_v.insert(L(j), pose_e.transformFrom(r * u))


def _preintegrate(log: DroneLog, params, bias: gtsam.imuBias.ConstantBias, e: int,
                  start: int | None = None):
    """The IMU samples from epoch ``start`` (default ``e - 1``) to ``e`` preintegrated
    about ``bias``."""
    k0, k1 = int(log.steps[e - 1 if start is None else start]), int(log.steps[e])
    pim = gtsam.PreintegratedCombinedMeasurements(params, bias)
    for acc, gyr in zip(log.accel[k0:k1], log.gyro[k0:k1]):
        pim.integrateMeasurement(acc, gyr, log.nav.dt)
    return pim


def _prior_preintegrations(log: DroneLog, params) -> list:
    """Every interval preintegrated once about the prior bias (the log's ``x0``): element
    ``e - 1`` is the interval ``(e - 1, e]``."""
    b0 = _bias(log.x0)
    return [_preintegrate(log, params, b0, e) for e in range(1, log.n_epochs)]


def _isam(graph: gtsam.NonlinearFactorGraph, vals: gtsam.Values) -> gtsam.ISAM2:
    isam_params = gtsam.ISAM2Params()
    isam_params.setFactorization("QR")  # Cholesky reports this graph indeterminate
    isam_params.setRelinearizeThreshold(RELIN_THRESHOLD)
    isam_params.relinearizeSkip = RELIN_SKIP
    isam = gtsam.ISAM2(isam_params)
    isam.update(graph, vals)
    return isam


def _solve_isam(log: DroneLog, params, obs_cov: Array, feed: int, pims: list | None,
                on_update: Callable[[int, gtsam.ISAM2], None] | None = None
                ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values, set[int]]:
    """The factor graph fed to iSAM2 ``feed`` epochs per update, each new state predicted
    by preintegration from iSAM2's estimate at the start of its update.  ``pims``: the
    intervals preintegrated beforehand (:func:`_prior_preintegrations`); None: each
    interval preintegrated about iSAM2's bias estimate at the start of its update (the
    graph then depends on ``feed``).  ``on_update(e, isam)`` is called after the priors'
    update (``e = 0``) and after each update ending with epoch ``e`` (the online row,
    :mod:`slam.kinds.drone.online`).  Returns the graph, iSAM2's final estimate and the
    landmarks seen."""
    graph, vals = _prior_factors(log)
    pose_prev, vel_prev, bias_prev = vals.atPose3(X(0)), vals.atVector(V(0)), _bias(log.x0)
    isam = _isam(graph, vals)
    if on_update is not None:
        on_update(0, isam)
    obs_at, seen, E = log.observations_at(), set(), log.n_epochs
    new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for e in range(1, E):
        pim = _preintegrate(log, params, bias_prev, e) if pims is None else pims[e - 1]
        new_f.add(gtsam.CombinedImuFactor(X(e - 1), V(e - 1), X(e), V(e), B(e - 1), B(e), pim))
        pred = pim.predict(gtsam.NavState(pose_prev, vel_prev), bias_prev)
        pose_prev, vel_prev = pred.pose(), pred.velocity()
        new_v.insert(X(e), pose_prev)
        new_v.insert(V(e), vel_prev)
        new_v.insert(B(e), bias_prev)
        sl = obs_at.get(e)
        if sl is not None:
            _landmark_factors(log, e, sl, pose_prev, obs_cov, seen, new_f, new_v)
        if e % feed and e < E - 1:
            continue
        graph.push_back(new_f)
        isam.update(new_f, new_v)
        new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        pose_prev = isam.calculateEstimatePose3(X(e))
        vel_prev = isam.calculateEstimateVector(V(e))
        bias_prev = isam.calculateEstimateConstantBias(B(e))
        if on_update is not None:
            on_update(e, isam)
    return graph, isam.calculateEstimate(), seen


def _keyframe_estimate(log: DroneLog, params, sightings: tuple[list, Array]
                       ) -> tuple[gtsam.Values, list[int]]:
    """iSAM2's estimate on the keyframes: every ``KEYFRAME``-th epoch (and the last), one
    ``CombinedImuFactor`` per keyframe interval (preintegrated about the prior bias) and
    the keyframes' sightings, fed ``KEYFRAME_FEED`` keyframes per update."""
    E, b0 = log.n_epochs, _bias(log.x0)
    keys = list(range(0, E, KEYFRAME))
    if keys[-1] != E - 1:
        keys.append(E - 1)
    graph, vals = _prior_factors(log)
    isam = _isam(graph, vals)
    pose, vel, bias = vals.atPose3(X(0)), vals.atVector(V(0)), b0
    obs_at, seen = log.observations_at(), set()
    new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for i in range(1, len(keys)):
        e0, e1 = keys[i - 1], keys[i]
        pim = _preintegrate(log, params, b0, e1, e0)
        new_f.add(gtsam.CombinedImuFactor(X(e0), V(e0), X(e1), V(e1), B(e0), B(e1), pim))
        pred = pim.predict(gtsam.NavState(pose, vel), bias)
        pose, vel = pred.pose(), pred.velocity()
        # keyword arguments: pybind11 skips the other overloads by name, not by a failed
        # conversion (ConstantBias is the 44th of Values.insert's 46)
        new_v.insert(X(e1), pose3=pose)
        new_v.insert(V(e1), vector=vel)
        new_v.insert(B(e1), constant_bias=bias)
        sl = obs_at.get(e1)
        if sl is not None:
            add_sightings(log, sl, pose, sightings, seen, new_f, new_v)
        if i % KEYFRAME_FEED and i < len(keys) - 1:
            continue
        isam.update(new_f, new_v)
        new_f, new_v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        pose = isam.calculateEstimatePose3(X(e1))
        vel = isam.calculateEstimateVector(V(e1))
        bias = isam.calculateEstimateConstantBias(B(e1))
    return isam.calculateEstimate(), keys


def _solve_keyframes(log: DroneLog, params, obs_cov: Array, pims: list
                     ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values, set[int]]:
    """The whole graph (``pims`` about the prior bias) with its initial values: the
    keyframes' estimate (:func:`_keyframe_estimate`), the epochs between predicted from
    the keyframe before them, a landmark no keyframe saw from its first sighting."""
    sightings = sightings_factors(log, obs_cov)
    est, keys = _keyframe_estimate(log, params, sightings)
    is_key = set(keys)
    graph, _ = _prior_factors(log)
    init, obs_at, seen = gtsam.Values(), log.observations_at(), set()
    for e in range(log.n_epochs):
        if e in is_key:
            pose, vel, bias = est.atPose3(X(e)), est.atVector(V(e)), est.atConstantBias(B(e))
        else:
            pred = pims[e - 1].predict(gtsam.NavState(pose, vel), bias)
            pose, vel = pred.pose(), pred.velocity()
        init.insert(X(e), pose3=pose)
        init.insert(V(e), vector=vel)
        init.insert(B(e), constant_bias=bias)
        if e:
            graph.add(gtsam.CombinedImuFactor(X(e - 1), V(e - 1), X(e), V(e), B(e - 1), B(e),
                                              pims[e - 1]))
        sl = obs_at.get(e)
        if sl is not None:
            add_sightings(log, sl, pose, sightings, seen, graph, init)
    for j in seen:
        if est.exists(L(j)):
            init.update(L(j), est.atPoint3(L(j)))
    return graph, init, seen


def _polish(graph: gtsam.NonlinearFactorGraph, init: gtsam.Values, rel_tol: float
            ) -> gtsam.Values:
    """Batch Levenberg-Marquardt from ``init`` to the optimum of ``graph``."""
    lm_params = gtsam.LevenbergMarquardtParams()
    lm_params.setRelativeErrorTol(rel_tol)
    lm_params.setAbsoluteErrorTol(1e-12)
    lm_params.setMaxIterations(50)
    return gtsam.LevenbergMarquardtOptimizer(graph, init, lm_params).optimize()


def solve_graph(log: DroneLog, *, imu_noise_scale: float = 1.0, sensor_noise_scale: float = 1.0,
                schedule: str = SCHEDULE, bias_point: str = BIAS_POINT,
                lm_rel_tol: float | None = None
                ) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values, set[int]]:
    """The smoother's graph, its optimum and the landmarks seen (module docstring,
    "Solving"): ``schedule`` ``"epochs"`` or ``"keyframes"``, ``bias_point``
    ``"estimate"`` (``"epochs"`` only) or ``"prior"``; the LM's relative tolerance
    ``lm_rel_tol`` (None: the schedule's, :data:`LM_REL_TOL`)."""
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule {schedule!r}: one of {', '.join(SCHEDULES)}")
    if bias_point not in BIAS_POINTS or (bias_point, schedule) == ("estimate", "keyframes"):
        raise ValueError(f"bias_point {bias_point!r} with schedule {schedule!r}: 'prior', "
                         "or 'estimate' with schedule 'epochs'")
    params = preintegration_params(log, imu_noise_scale)
    obs_cov = log.obs_cov * sensor_noise_scale
    pims = _prior_preintegrations(log, params) if bias_point == "prior" else None
    if schedule == "epochs":
        graph, init, seen = _solve_isam(log, params, obs_cov, ISAM_BATCH, pims)
    else:
        graph, init, seen = _solve_keyframes(log, params, obs_cov, pims or [])
    tol = LM_REL_TOL[schedule] if lm_rel_tol is None else lm_rel_tol
    return graph, _polish(graph, init, tol), seen


def _marginals(graph, values, Rs: Array, ids: Array, method: str) -> tuple[Array, Array]:
    """World-frame ``[δp, δθ]`` pose covariances (E, 6, 6) and landmark covariances:
    ``method`` ``"joint"`` by GTSAM's ``Marginals``, ``"chain"`` by the square-root sweep
    (:mod:`slam.chain_marginals`; epoch columns ``[X, V, B]``, the landmarks global)."""
    E = len(Rs)
    if method == "chain":
        slots = {X(e): (e, 0) for e in range(E)}
        slots.update({V(e): (e, 6) for e in range(E)})
        slots.update({B(e): (e, 9) for e in range(E)})
        slots.update({L(int(j)): (-1, 3 * i) for i, j in enumerate(ids)})
        local, glob, base = jacobian_rows(graph, values, slots, 15, 3 * len(ids))
        sig, _, s_ll = chain_marginals(local, glob, base, E)
        lcov = np.array([s_ll[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(ids))])
        return pose3_world_cov(sig[:, :6, :6], Rs), lcov.reshape(-1, 3, 3)
    marg = gtsam.Marginals(graph, values)
    S = np.array([marg.marginalCovariance(X(e)) for e in range(E)])
    lcov = np.array([marg.marginalCovariance(L(int(j))) for j in ids]).reshape(-1, 3, 3)
    return pose3_world_cov(S, Rs), lcov


class StateRows:
    """Per-epoch states read from GTSAM in the filters' layout: position ``p`` (E, 3),
    velocity ``v`` (E, 3), bias ``[b_g, b_a]`` (E, 6; GTSAM stores ``[acc, gyro]``) and
    attitude matrices ``Rs`` (E, 3, 3)."""

    def __init__(self, E: int):
        self.p, self.v, self.bias = np.empty((E, 3)), np.empty((E, 3)), np.empty((E, 6))
        self.Rs = np.empty((E, 3, 3))

    def put(self, e: int, pose: gtsam.Pose3, vel: Array,
            bias: gtsam.imuBias.ConstantBias) -> None:
        self.Rs[e] = pose.rotation().matrix()
        self.p[e] = pose.translation()
        self.v[e] = vel
        bv = bias.vector()
        self.bias[e, :3], self.bias[e, 3:] = bv[3:], bv[:3]


def _read_states(values: gtsam.Values, E: int) -> tuple[Array, Array, Array, Array]:
    """:class:`StateRows`' ``p, v, bias, Rs`` of every epoch, read in bulk (the poses and
    velocities in key order, ``X(0..E-1)`` and ``V(0..E-1)``: the graph's only ``Pose3``
    and ``v`` vectors)."""
    poses = gtsam.utilities.extractPose3(values)
    vel = gtsam.utilities.extractVectors(values, "v")
    if poses.shape != (E, 12) or vel.shape != (E, 3):
        raise ValueError(f"expected {E} poses and velocities, got {poses.shape}, {vel.shape}")
    bv = np.array([values.atConstantBias(B(e)).vector() for e in range(E)])
    bias = np.hstack([bv[:, 3:], bv[:, :3]])
    return poses[:, 9:].copy(), vel.copy(), bias, poses[:, :9].reshape(E, 3, 3).copy()


def smooth_drone(log: DroneLog, *, imu_noise_scale: float = 1.0,
                 sensor_noise_scale: float = 1.0, marginals: bool = True,
                 schedule: str = SCHEDULE, bias_point: str = BIAS_POINT,
                 marginal_method: str = MARGINAL_METHOD, lm_rel_tol: float | None = None
                 ) -> DroneEstimate:
    """Smooth a drone log with GTSAM (iSAM2 over the epochs, then an LM polish;
    ``schedule``, ``bias_point`` and ``lm_rel_tol`` as :func:`solve_graph`;
    ``marginal_method`` as :func:`_marginals`).

    ``time_s`` covers the graph, iSAM2 and LM; ``extra_time_s`` the marginals.
    """
    if marginal_method not in MARGINAL_METHODS:
        raise ValueError(f"marginal_method {marginal_method!r}: one of "
                         f"{', '.join(MARGINAL_METHODS)}")
    t_start = time.perf_counter()
    E = log.n_epochs
    graph, values, seen = solve_graph(log, imu_noise_scale=imu_noise_scale,
                                      sensor_noise_scale=sensor_noise_scale,
                                      schedule=schedule, bias_point=bias_point,
                                      lm_rel_tol=lm_rel_tol)
    p, v, bias, Rs = _read_states(values, E)
    q = dcm_to_q(Rs)
    ids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([values.atPoint3(L(int(j))) for j in ids], dtype=float).reshape(-1, 3)
    t_solved = time.perf_counter()
    if marginals:
        pcov, lcov = _marginals(graph, values, Rs, ids, marginal_method)
    else:
        pcov, lcov = np.full((E, 6, 6), np.nan), np.full((len(ids), 3, 3), np.nan)
    t_end = time.perf_counter()
    return DroneEstimate(REFERENCE, p, v, q, bias, pcov, ids, lms, lcov, nis=np.zeros(0),
                         nis_dof=np.zeros(0, int), time_s=t_solved - t_start, steps=E - 1,
                         extra_time_s=t_end - t_solved)


def failed_reference(log: DroneLog, failure: str) -> DroneEstimate:
    """The smoother's entry of a run it failed on (:mod:`slam.failures`): no estimate,
    diverged with its reason."""
    E = log.n_epochs
    nan = np.full((E, 3), np.nan)
    return DroneEstimate(REFERENCE, nan, nan, np.full((E, 4), np.nan), np.full((E, 6), np.nan),
                         np.full((E, 6, 6), np.nan), np.zeros(0, int), np.zeros((0, 3)),
                         np.zeros((0, 3, 3)), nis=np.zeros(0), nis_dof=np.zeros(0, int),
                         time_s=0.0, steps=E - 1, diverged=True, failure=failure)
