"""Star-sensor simulation (:mod:`slam.kinds.attitude.simulate`): noise-free logs reproduce
the truth; noise levels and reproducibility.
"""

from __future__ import annotations

import math

import numpy as np

import slam.kinds.attitude.run as att
from nav.quaternion import qlog, qmul, qpropagate
from nav.spaces import UnitQuaternion
from slam.kinds.attitude.simulate import simulate_attitude
from tests.small_worlds import short_star_sensor_world

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]

def test_noise_free_log_reproduces_the_truth() -> None:
    w = short_star_sensor_world(30.0, **{"gyro.arw_deg_sqrt_h": 0.0,
                                         "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                                         "star_sensor.sigma_arcsec": 0.0})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(0))
    assert log.gyro.shape == (1500, 3) and log.star_q.shape == (61, 4)
    q = log.truth_q[0]
    for k in range(log.gyro.shape[0]):  # ideal integrating gyro: exact increments
        q = qpropagate(q, log.gyro[k] - log.truth_bias[k], log.dt)
    assert np.linalg.norm(qlog(qmul(q * [1, -1, -1, -1], log.truth_q[-1]))) < 1e-11
    assert np.abs(log.star_q - log.star_truth_q).max() < 1e-15
    assert np.allclose(log.truth_bias, 0.1 * DEG_H, rtol=0, atol=1e-20)
    # the body rate relative to inertial space turns with the orbit: not constant
    rates = log.gyro - log.truth_bias[:-1]
    assert np.abs(rates[-1] - rates[0]).max() > 1e-5


def test_simulated_noise_levels_and_reproducibility() -> None:
    w = short_star_sensor_world(300.0, **{"gyro.bias_rw_deg_h_sqrt_h": 100.0})
    cfg = att.sim_config(w)
    log = simulate_attitude(cfg, np.random.default_rng(7))
    again = simulate_attitude(cfg, np.random.default_rng(7))
    assert np.array_equal(log.gyro, again.gyro) and np.array_equal(log.star_q, again.star_q)
    truth = simulate_attitude(att.sim_config(short_star_sensor_world(
        300.0, **{"gyro.arw_deg_sqrt_h": 0.0, "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                  "star_sensor.sigma_arcsec": 0.0})), np.random.default_rng(7))
    arw = log.gyro - (truth.gyro - truth.truth_bias[:-1]) - log.truth_bias[:-1]
    assert math.isclose(arw.std(), w.gyro.arw_rad_sqrt_s / math.sqrt(log.dt), rel_tol=0.03)
    steps = np.diff(log.truth_bias, axis=0)
    assert math.isclose(steps.std(), w.gyro.bias_rw_rad_s_sqrt_s * math.sqrt(log.dt),
                        rel_tol=0.03)
    star = UnitQuaternion().local(log.star_truth_q, log.star_q)
    assert math.isclose(star.std(), w.star.sigma_rad, rel_tol=0.06)
