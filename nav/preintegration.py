"""GTSAM's combined IMU preintegration parameters from the IMU's per-axis variances: the
IMU model of the smoothers that serve as references (gtsam is imported on first use)."""

from __future__ import annotations

from typing import Any

import numpy as np

VAR_FLOOR = 1e-20
"""Variance floor of the densities (keeps a zero random walk finite)."""


def combined_params(gravity: float, gyro_var: float, accel_var: float, gyro_bias_var: float,
                    accel_bias_var: float, *, earth_rate: Any = None,
                    integration_var: float = 1e-12, floor: float = VAR_FLOOR) -> Any:
    """``gtsam.PreintegrationCombinedParams`` for gravity ``gravity`` (m/s², along -z):
    the gyro and accelerometer white-noise and bias random-walk variances per axis (each at
    least ``floor``), the integration variance, and the Earth rate (None: none)."""
    import gtsam

    p = gtsam.PreintegrationCombinedParams.MakeSharedU(gravity)
    eye = np.eye(3)
    p.setGyroscopeCovariance(max(gyro_var, floor) * eye)
    p.setAccelerometerCovariance(max(accel_var, floor) * eye)
    p.setIntegrationCovariance(integration_var * eye)
    p.setBiasOmegaCovariance(max(gyro_bias_var, floor) * eye)
    p.setBiasAccCovariance(max(accel_bias_var, floor) * eye)
    if earth_rate is not None:
        p.setOmegaCoriolis(np.asarray(earth_rate, dtype=float))
    return p





def _so3_exp_right_jacobian(theta: Any) -> tuple[Any, Any]:
    r"""``(Exp(θ), J_r(θ))`` for (..., 3) rotation vectors:
    :math:`\mathrm{Exp}(θ) = I + a W + b W^2`, :math:`J_r(θ) = I - b W + c W^2` with
    :math:`W = [θ]_\times`, :math:`W^2 = θθ^\top - t^2 I`, :math:`a = \sin t/t`,
    :math:`b = (1 - \cos t)/t^2`, :math:`c = (t - \sin t)/t^3`, :math:`t = |θ|` (Taylor
    series below :math:`t = 10^{-3}`); built entry by entry on contiguous planes."""
    shape = theta.shape[:-1]
    x, y, z = np.reshape(theta, (-1, 3)).T.copy()
    xx, yy, zz = x * x, y * y, z * z
    t2 = xx + yy + zz
    a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
    b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
    c = (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0)) / 6.0
    big = np.flatnonzero(t2 >= 1e-6)
    if big.size:
        tb = np.sqrt(t2[big])
        sin = np.sin(tb)
        a[big], b[big] = sin / tb, 2.0 * np.sin(0.5 * tb) ** 2 / t2[big]
        c[big] = (tb - sin) / (tb * t2[big])
    xy, xz, yz = x * y, x * z, y * z
    planes = np.empty((2, 3, 3, x.size))
    for out, s, k in ((planes[0], b, a), (planes[1], c, -b)):  # I + k W + s W²
        out[0, 0], out[1, 1], out[2, 2] = 1.0 - s * (yy + zz), 1.0 - s * (xx + zz), \
            1.0 - s * (xx + yy)
        sxy, sxz, syz, kx, ky, kz = s * xy, s * xz, s * yz, k * x, k * y, k * z
        out[0, 1], out[1, 0] = sxy - kz, sxy + kz
        out[0, 2], out[2, 0] = sxz + ky, sxz - ky
        out[1, 2], out[2, 1] = syz - kx, syz + kx
    E, J = np.moveaxis(planes, -1, 1).reshape((2,) + shape + (3, 3))
    return E, J


def preintegrate_rotation(gyro: Any, dt: float, gyro_var: float
                          ) -> tuple[float, Any, Any, Any]:
    r"""GTSAM's ``PreintegratedAhrsMeasurements`` (zero bias point, isotropic gyro
    covariance :math:`σ_g^2 I`) of many intervals at once: ``gyro`` (m, n, 3), n samples
    of ``dt`` per interval.  Per sample, with :math:`E = \mathrm{Exp}(\tilde\omega\,dt)`,
    :math:`J_r = J_r(\tilde\omega\,dt)`:

    .. math::

        ΔR \leftarrow ΔR\,E,\quad
        \frac{\partial ΔR}{\partial b} \leftarrow E^\top \frac{\partial ΔR}{\partial b}
        - J_r\,dt,\quad
        Σ \leftarrow E^\top Σ E + σ_g^2\,dt\,I = σ_g^2\,ΔT\,I

    (:math:`E^\top E = I`, so the covariance stays isotropic; GTSAM's recursion gives it
    to round-off).  Returns ``(ΔT, ΔR (m, 3, 3), ∂ΔR/∂b (m, 3, 3), Σ (m, 3, 3))``;
    ``ΔT`` summed as GTSAM sums it."""
    w = np.asarray(gyro, dtype=np.float64)
    m, n = w.shape[:2]
    E, Jr = _so3_exp_right_jacobian(np.swapaxes(w, 0, 1) * dt)  # (n, m, 3, 3)
    Jt = np.swapaxes(Jr, -1, -2) * dt  # the recursion transposed: Dᵀ ← Dᵀ E - J_rᵀ dt
    R, Dt = E[0], -Jt[0]
    T = dt
    for k in range(1, n):
        R, Dt = R @ E[k], Dt @ E[k] - Jt[k]
        T += dt
    C = np.broadcast_to(gyro_var * T * np.eye(3), (m, 3, 3)).copy()
    return T, R, np.ascontiguousarray(np.swapaxes(Dt, -1, -2)), C


def pose3_world_cov(S: Any, Rs: Any) -> Any:
    r"""GTSAM ``Pose3`` covariances (E, 6, 6) in its body tangent ``[ω, v]`` (the pose moved
    to :math:`R\,\mathrm{Exp}(ω)`, :math:`t + R v`) as the filters' ``[δp (world), δθ
    (body)]`` ones at the attitudes ``Rs`` (E, 3, 3): :math:`[δp; δθ] = J [ω; v]` with
    :math:`J = [[0, R], [I, 0]]`."""
    S, Rs = np.asarray(S, dtype=float), np.asarray(Rs, dtype=float)
    pcov = np.empty_like(S)
    RT = np.swapaxes(Rs, -1, -2)
    pcov[:, :3, :3] = Rs @ S[:, 3:, 3:] @ RT
    pcov[:, :3, 3:] = Rs @ S[:, 3:, :3]
    pcov[:, 3:, :3] = np.swapaxes(pcov[:, :3, 3:], -1, -2)
    pcov[:, 3:, 3:] = S[:, :3, :3]
    return pcov
