"""The star-sensor GTSAM smoother (:mod:`slam.kinds.attitude.run`)."""

from __future__ import annotations

import math

import numpy as np

import slam.kinds.attitude.run as att
from nav.spaces import UnitQuaternion
from slam.kinds.attitude.simulate import simulate_attitude
from tests.small_worlds import short_star_sensor_world

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]

def test_smoother_recovers_a_constant_drift() -> None:
    drift = np.array([20.0, -10.0, 15.0])  # deg/h; angle random walk limits it to ~0.2 deg/h
    w = short_star_sensor_world(300.0, **{"gyro.bias_deg_h": drift.tolist(),
                                          "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                                          "filters.initial_bias_var_deg_h2": 1e4})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(11))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    s = att.smooth_attitude(log, x0, P0, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s,
                            fs.star_sigma_rad, marginals=False)
    bias = s.means[:, 4:] / DEG_H
    assert np.abs(bias - drift).max() < 0.03 * np.linalg.norm(drift)
    err = UnitQuaternion().local(s.means[:, :4], log.star_truth_q)
    assert np.sqrt(np.mean(err**2)) < 10 * ARCSEC
