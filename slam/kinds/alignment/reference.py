r"""The GTSAM reference of the alignment: a batch smoother on the filters' own IMU data.

Graph (keys every ``key_interval_s``, :math:`k = 0 \dots K`):

* ``Pose3`` :math:`X_k` (attitude :math:`C(q_{nb})`, position), ``Vector3`` velocity
  :math:`V_k` and ``imuBias.ConstantBias`` :math:`B_k` (accelerometer, gyro);
* ``CombinedImuFactor(X_k, V_k, X_{k+1}, V_{k+1}, B_k, B_{k+1})`` from
  ``PreintegratedCombinedMeasurements`` of every 1 kHz reading of the interval, with
  ``PreintegrationCombinedParams.MakeSharedU(g)`` (ENU), the Earth rate as
  ``omegaCoriolis``, white-noise densities :math:`\sigma^2 dt` (the per-sample σ's) and
  bias random-walk densities :math:`2\sigma_m^2/\tau` (the filters' drift model);
* a zero-velocity factor ``PriorFactorVector(V_k, 0, σ_v)`` - the filters' reference and
  its σ - and a fixed-position factor ``GPSFactor(X_k, 0, σ_p)`` (the launcher's
  surveyed position; σ_p the wind deflection's size, ``[reference] position_sigma_m``);
* priors: :math:`X_0` at the SINS's initial attitude with the filters' misalignment σ
  (rotated into GTSAM's body-frame tangent), position 0; :math:`B_0 = 0` with the total
  drift/bias σ.

Started from the SINS's attitudes (the filter-independent dead reckoning of attitude)
with zero velocity, position and biases; solved by Levenberg-Marquardt.  Its attitude is
the batch answer for the misalignment; the marginal rotation covariance is turned from
GTSAM's body frame into the navigation frame (:math:`R\Sigma R^\top`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.preintegration import combined_params
from nav.quaternion import dcm_to_q, qto_dcm
from slam.kinds.alignment.simulate import AlignmentLog
from slam.kinds.alignment.world import AlignmentWorld

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SmoothSeries:
    """The smoother at its keys: q (K + 1, 4), cov_nav (K + 1, 3, 3) attitude covariance
    in the navigation frame (NaN when GTSAM's marginals fail: ``marginals_failure``, e.g.
    an indeterminate system when the azimuth prior is wide and the IMU factors are tight);
    time_s of build + solve + marginals; failure (of the solve) or ``None``."""

    q: Array
    cov_nav: Array
    time_s: float
    failure: str | None = None
    marginals_failure: str | None = None


def _params(world: AlignmentWorld, log: AlignmentLog) -> Any:
    m, dt = world.imu, log.dt
    return combined_params(float(-log.gravity[2]), m.gyro_white_rad_s**2 * dt,
                           m.accel_white_mps2**2 * dt,
                           2 * m.gyro_markov_rad_s**2 / m.gyro_markov_tau_s,
                           2 * m.accel_markov_mps2**2 / m.accel_markov_tau_s,
                           earth_rate=log.earth_rate, integration_var=1e-10, floor=1e-24)


def _priors(gtsam: Any, graph: Any, world: AlignmentWorld, q0: Array) -> None:
    f, m = world.filters, world.imu
    R = qto_dcm(q0)
    cov = np.zeros((6, 6))
    cov[:3, :3] = R.T @ np.diag(np.square(f.initial_sigma_rad)) @ R
    cov[3:, 3:] = world.reference.position_sigma_m**2 * np.eye(3)
    pose = gtsam.Pose3(gtsam.Rot3(R), np.zeros(3))
    graph.add(gtsam.PriorFactorPose3(gtsam.symbol("x", 0), pose,
                                     gtsam.noiseModel.Gaussian.Covariance(cov)))
    sig = np.concatenate([np.full(3, math.hypot(m.accel_bias_mps2, m.accel_markov_mps2)),
                          np.full(3, math.hypot(m.gyro_bias_rad_s, m.gyro_markov_rad_s))])
    graph.add(gtsam.PriorFactorConstantBias(gtsam.symbol("b", 0), gtsam.imuBias.ConstantBias(),
                                            gtsam.noiseModel.Diagonal.Sigmas(
                                                np.maximum(sig, 1e-12))))


def _build(gtsam: Any, world: AlignmentWorld, log: AlignmentLog) -> tuple[Any, Any, list]:
    """The graph, its initial values and the pose keys."""
    every, s = world.epochs_per_key, world.samples_per_epoch
    idx = np.arange(0, log.n_epochs, every)
    X, V, B = ([gtsam.symbol(c, k) for k in range(len(idx))] for c in "xvb")
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    _priors(gtsam, graph, world, log.sins_q[0])
    params = _params(world, log)
    vel = gtsam.noiseModel.Isotropic.Sigma(3, world.filters.velocity_sigma_mps)
    pos = gtsam.noiseModel.Isotropic.Sigma(3, world.reference.position_sigma_m)
    n = every * s
    for k, j in enumerate(idx):
        graph.add(gtsam.PriorFactorVector(V[k], np.zeros(3), vel))
        graph.add(gtsam.GPSFactor(X[k], np.zeros(3), pos))
        values.insert(X[k], gtsam.Pose3(gtsam.Rot3(qto_dcm(log.sins_q[j])), np.zeros(3)))
        values.insert(V[k], np.zeros(3))
        values.insert(B[k], gtsam.imuBias.ConstantBias())
        if k + 1 < len(idx):
            pim = gtsam.PreintegratedCombinedMeasurements(params, gtsam.imuBias.ConstantBias())
            for a, w in zip(log.accel[k * n:(k + 1) * n], log.gyro[k * n:(k + 1) * n]):
                pim.integrateMeasurement(a, w, log.dt)
            graph.add(gtsam.CombinedImuFactor(X[k], V[k], X[k + 1], V[k + 1], B[k], B[k + 1],
                                              pim))
    return graph, values, X


def smooth_alignment(world: AlignmentWorld, log: AlignmentLog) -> SmoothSeries:
    """GTSAM batch smoother on ``log`` (module docstring)."""
    import gtsam

    t0 = time.perf_counter()
    graph, values, X = _build(gtsam, world, log)
    K = len(X)
    try:
        params = gtsam.LevenbergMarquardtParams()
        params.setRelativeErrorTol(1e-10)
        params.setAbsoluteErrorTol(1e-12)
        result = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    except RuntimeError as exc:
        return SmoothSeries(np.full((K, 4), np.nan), np.full((K, 3, 3), np.nan),
                            time.perf_counter() - t0, f"{type(exc).__name__}: {exc}")
    Rs = np.stack([result.atPose3(x).rotation().matrix() for x in X])
    try:
        marg = gtsam.Marginals(graph, result)
        cov = np.stack([R @ marg.marginalCovariance(x)[:3, :3] @ R.T for x, R in zip(X, Rs)])
        why = None
    except RuntimeError as exc:  # counted in the summary, never hidden
        cov, why = np.full((K, 3, 3), np.nan), str(exc).strip().splitlines()[0]
    return SmoothSeries(dcm_to_q(Rs), cov, time.perf_counter() - t0, None, why)
