"""The spinning kind's filter models and runs (:mod:`slam.kinds.spinning.models`): the
analytic Jacobian, a noise-free log tracked to round-off (eq. 3 with the magnetometer
roll), the time update's noise through eq. 3, the world's filter settings reaching the
filters, SR-CH∞KF at γ = ∞ equal to the SRCKF, and the H∞ existence check counted or
ending the run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimators import NoiseError
from slam.kinds.spinning import models as M
from slam.kinds.spinning.simulate import sim_config, simulate
from slam.kinds.spinning.truth import axial_field
from tests.slam.kinds.spinning.helpers import tiny_world

DEG = math.pi / 180.0
FILTERS = ("ukf", "ckf", "srckf", "svdckf", "srchinf", "uthinf", "ekf")


def _log(seed: int = 0, **overrides):
    w = tiny_world(**overrides)
    rng = np.random.default_rng(seed)
    log = simulate(sim_config(w), rng)
    return w, log, M.world_models(w, log, rng)


def test_axial_jacobian_matches_finite_differences() -> None:
    w = tiny_world()
    rng = np.random.default_rng(4)
    for x in rng.uniform([-1.3, -3.0], [1.3, 3.0], (20, 2)):
        H = M.axial_jacobian(w.field, x)
        h = 1e-6
        num = [(axial_field(w.field, *(x + h * e)) - axial_field(w.field, *(x - h * e))) / (2 * h)
               for e in np.eye(2)]
        assert np.allclose(H[0], num, rtol=1e-6, atol=1e-4)


def test_noise_free_log_is_tracked_to_round_off() -> None:
    w, log, m = _log(**{"truth_noise.magnetometer_factor": 0.0, "truth_noise.gyro_factor": 0.0})
    # the EKF with the world's noise: its innovations are exactly zero
    exact = M.Models(m.gyro, m.measurement, log.truth[0], m.P0, m.settings)
    s = M.run_filter(log, "ekf", exact)
    assert np.abs(s.means - log.truth).max() < 1e-12
    # every filter, told the noise is tiny (so the sigma points' curvature term vanishes)
    settings = {n: {**m.settings[n], "gamma": math.inf} if "gamma" in m.settings[n]
                else m.settings[n] for n in m.settings}
    tiny = M.Models(M.GyroModel(log.dt, 1e-10, w.field), M.measurement(w.field, 1e-6),
                    log.truth[0], 1e-20 * np.eye(2), settings)
    for name in FILTERS:
        s = M.run_filter(log, name, tiny)
        assert not s.diverged, (name, s.failure)
        assert np.abs(s.means - log.truth).max() < 1e-9, name


@pytest.mark.parametrize(("hinf", "twin"), [("srchinf", "srckf"), ("uthinf", "ukf")])
def test_hinf_at_infinite_gamma_is_its_kalman_twin(hinf: str, twin: str) -> None:
    _, log, m = _log(seed=5, **{"truth_noise.magnetometer_factor": 3.0})
    m = m.with_settings(hinf, gamma=math.inf)
    a, b = M.run_filter(log, hinf, m), M.run_filter(log, twin, m)
    assert np.abs(a.means - b.means).max() < 1e-9
    assert np.abs(a.covs - b.covs).max() < 1e-9 * np.abs(b.covs).max()
    assert a.fallbacks == 0 and a.updates == log.n_epochs


def test_existence_check_failures_are_counted_or_end_the_run() -> None:
    _, log, m = _log(seed=6)
    small = m.with_settings("srchinf", gamma=0.01, on_failure="kalman")
    s = M.run_filter(log, "srchinf", small)
    assert 0 < s.fallbacks <= s.updates == log.n_epochs and not s.diverged
    assert len(s.fallback_epochs) == s.fallbacks
    raising = m.with_settings("srchinf", gamma=0.01, on_failure="raise")
    r = M.run_filter(log, "srchinf", raising)
    assert r.diverged and "RiccatiConditionError" in r.failure


def test_time_update_noise_is_the_gyro_noise_through_eq3() -> None:
    g = M.GyroModel(0.1, 0.05 * DEG, tiny_world().field)
    q = g.transition(60 * DEG).noise.cov
    base = (0.05 * DEG) ** 2 * 0.1
    assert np.allclose(q, np.diag([base, base / math.cos(60 * DEG) ** 2]), rtol=1e-12)
    with pytest.raises(NoiseError, match="not finite"):  # a counted divergence in a run
        M.RateNoise.of(1e-3, math.inf)


def test_the_worlds_settings_reach_the_filters() -> None:
    w, log, m = _log()
    assert m.settings["ukf"] == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert m.settings["srchinf"]["gamma"] == w.filters.gamma_rad
    # the UKF with Julier's set is not the cubature filter on this nonlinear model
    a, b = M.run_filter(log, "ukf", m), M.run_filter(log, "ckf", m)
    assert np.abs(a.means - b.means).max() > 1e-9
