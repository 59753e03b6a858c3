"""Star-sensor attitude world files (:mod:`slam.kinds.attitude.world`): the bundled worlds,
errors naming the key and the file.
"""

from __future__ import annotations

import json
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from slam.kinds.attitude.world import AttitudeWorld
from slam.registry import load_world
from tests.small_worlds import star_sensor_world
from worlds import WorldError

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]

def test_bundled_attitude_worlds_load() -> None:
    w = load_world("star-sensor")
    assert isinstance(w, AttitudeWorld) and w.kind == "attitude"
    assert (w.duration_s, w.runs, w.n_star, w.samples_per_star) == (600.0, 50, 1201, 25)
    assert w.filters.names == ("srckf", "srukf", "srcdkf", "ekf")
    assert math.isclose(w.gyro.arw_rad_sqrt_s, 0.05 * DEG / 60.0)
    assert math.isclose(w.gyro.bias_rw_rad_s_sqrt_s, 0.02 * DEG_H / 60.0)
    assert np.allclose(w.gyro.bias_rad_s, 0.1 * DEG_H)
    assert math.isclose(w.star.sigma_rad, 20.0 * ARCSEC) and w.star.mode == "quaternion"
    assert math.isclose(w.filters.initial_attitude_var_rad2, 0.25 * DEG**2)
    assert math.isclose(w.filters.initial_bias_var_rad2_s2, 0.2 * DEG_H**2)
    assert np.allclose(w.filters.initial_error_rad, np.array([0.5, 0.5, 5.0]) * DEG)
    assert np.allclose(w.satellite.initial_attitude_rad, np.array([0.0, 0.0, 5.0]) * DEG)
    assert w.scoring.steady_state_from_s == 300.0 and not w.scoring.report_convergence
    assert w.paper["filters"]["srckf"] == {"roll_arcsec": 3.0, "pitch_arcsec": 5.0,
                                           "yaw_arcsec": 2.0, "time_per_iteration_s": 0.012}
    json.dumps(w.paper)
    big = load_world("star-sensor-large-error")
    assert big.duration_s == 300.0 and big.scoring.report_convergence
    assert np.allclose(big.filters.initial_error_rad, np.array([30.0, 30.0, 60.0]) / 60 * DEG)


@pytest.mark.parametrize(
    ("overrides", "key"),
    [
        ({"star_sensor.rate_hz": 3.0}, "star_sensor.rate_hz"),  # 50 Hz / 3 Hz not whole
        ({"star_sensor.rate_hz": 1e-308}, "star_sensor.rate_hz"),  # 50 Hz / rate = inf
        ({"star_sensor.mode": "euler"}, "star_sensor.mode"),
        ({"scoring.steady_state_from_s": 600.0}, "scoring.steady_state_from_s"),
        ({"filters.initial_error_deg": [0.5, 0.5]}, "filters.initial_error_deg"),
        ({"gyro.arw_deg_sqrt_h": -0.05}, "gyro.arw_deg_sqrt_h"),
        ({"filters.star_sigma_arcsec": 0.0}, "filters.star_sigma_arcsec"),
        ({"gyro.arw_deg_sqrt_hour": 0.05}, "gyro.arw_deg_sqrt_hour"),  # misspelt key
        ({"filters.names": ["srckf", "kalman"]}, "filters.names[1]"),
        ({"duration_s": 600.25}, "duration_s"),
        ({"star_sensor.mode": "vectors", "star_sensor.directions": [[1, 0, 0], [2, 0, 0]]},
         "star_sensor.directions"),
        ({"star_sensor.n_stars": 3, "star_sensor.directions": [[1, 0, 0], [0, 1, 0]]},
         "star_sensor.directions"),
    ],
)
def test_malformed_attitude_world_names_the_key(overrides: dict, key: str) -> None:
    with pytest.raises(WorldError) as info:
        star_sensor_world(**overrides)
    assert info.value.key == key


def test_malformed_attitude_world_file_names_the_file(tmp_path: Path) -> None:
    text = (files("worlds") / "star-sensor.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("rate_hz = 50.0", "rate_hz = -50.0"), encoding="utf-8")
    with pytest.raises(WorldError) as info:
        load_world(bad)
    assert info.value.key == "gyro.rate_hz" and str(bad) in str(info.value)
    missing = tmp_path / "missing.toml"
    start = text.index("[gyro]")
    missing.write_text(text[:start] + text[text.index("[star_sensor]"):], encoding="utf-8")
    with pytest.raises(WorldError, match=r"gyro.*missing section"):
        load_world(missing)
