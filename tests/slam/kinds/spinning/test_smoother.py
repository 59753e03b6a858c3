"""The GTSAM smoother of the spinning kind: the ``CustomFactor``'s analytic Jacobian,
exact recovery of a noise-free log, and a χ² test of its marginals."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2

from slam.kinds.spinning import models as M
from slam.kinds.spinning.simulate import sim_config, simulate
from tests.slam.kinds.spinning.helpers import tiny_world


def test_custom_factor_jacobian_matches_finite_differences() -> None:
    import gtsam

    w = tiny_world()
    key = gtsam.symbol("x", 0)
    factor = gtsam.CustomFactor(gtsam.noiseModel.Isotropic.Sigma(1, 100.0), [key],
                                M._axial(w.field, 20_000.0))
    for x in ([0.3, -0.2], [-0.8, 0.05], [1.2, 2.5]):
        v = gtsam.Values()
        v.insert(key, np.array(x))
        H = factor.linearize(v).jacobian()[0] * 100.0  # unwhitened
        num = np.zeros(2)
        for i in range(2):
            d = np.zeros(2)
            d[i] = 1e-6
            up, down = gtsam.Values(), gtsam.Values()
            up.insert(key, np.array(x) + d)
            down.insert(key, np.array(x) - d)
            num[i] = (factor.unwhitenedError(up)[0] - factor.unwhitenedError(down)[0]) / 2e-6
        assert np.allclose(H[0], num, rtol=1e-6, atol=1e-4)


def _run(w, seed: int):
    rng = np.random.default_rng(seed)
    log = simulate(sim_config(w), rng)
    m = M.world_models(w, log, rng)
    s = M.smooth(log, m, w.field, w.gyro.rate_noise_rad_s_sqrt_hz, w.magnetometer.noise_nt)
    return log, m, s


def test_smoother_recovers_a_noise_free_log() -> None:  # eq. 3 factors with its own roll
    w = tiny_world(**{"truth_noise.magnetometer_factor": 0.0, "truth_noise.gyro_factor": 0.0})
    log, m, _ = _run(w, 1)
    exact = M.Models(m.gyro, m.measurement, log.truth[0], m.P0, m.settings)
    s = M.smooth(log, exact, w.field, w.gyro.rate_noise_rad_s_sqrt_hz, w.magnetometer.noise_nt,
                 marginals=False)
    assert np.abs(s.means - log.truth).max() < 1e-9


def test_smoother_marginals_pass_a_chi2_nees_test() -> None:
    """NEES at one epoch per run (independent across runs): the sum over R runs is
    χ²(2R) for consistent marginals; checked at the 99.8 % two-sided level."""
    w = tiny_world()
    R, total = 12, 0.0
    for r in range(R):
        log, _, s = _run(w, 100 + r)
        k = log.n_epochs // 2
        e = s.means[k] - log.truth[k]
        total += float(e @ np.linalg.solve(s.covs[k], e))
    lo, hi = chi2.ppf([0.001, 0.999], 2 * R)
    assert lo < total < hi, (total, lo, hi)
    assert math.isfinite(total)
