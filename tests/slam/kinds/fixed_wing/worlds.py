"""Fixed-wing test worlds (not a test module): the bundled ``fixed-wing`` document with
dotted-key overrides, validated through the kind's schema, and short flights."""

from __future__ import annotations

import tomllib
from functools import reduce
from importlib.resources import files
from typing import Any

from slam.kinds.fixed_wing.world import FixedWingWorld
from slam.registry import world_from_dict

#: A 30 s flight: climb-out with a speed change at 5-10 s, a left turn from 15 s.
SHORT_FLIGHT = {"duration_s": 30.0, "flight.manoeuvre_start_s": [5.0, 15.0],
                "flight.manoeuvre_ramp_s": [5.0, 4.0], "flight.turn_rate_deg_s": [0.0, 9.0],
                "flight.climb_deg": [0.0, 0.0], "flight.speed_mps": [25.0, 25.0]}

#: Straight and level at constant speed (the accelerometer senses gravity only).
LEVEL_FLIGHT = {"flight.start_climb_deg": 0.0, "flight.start_speed_mps": 25.0,
                "flight.manoeuvre_start_s": [1.0], "flight.manoeuvre_ramp_s": [1.0],
                "flight.turn_rate_deg_s": [0.0], "flight.climb_deg": [0.0],
                "flight.speed_mps": [25.0]}

NOISE_FREE = {"imu.gyro_bias_sigma_deg_h": 0.0, "imu.gyro_drift_rw_deg_h_sqrt_h": 0.0,
              "imu.gyro_arw_deg_sqrt_h": 0.0, "imu.accel_drift_sigma_mg": 0.0,
              "imu.accel_drift_rw_mg_sqrt_h": 0.0, "imu.accel_vrw_mps_sqrt_h": 0.0,
              "magnetometer.sigma_ut": 0.0}


def fw_doc(**overrides: Any) -> dict[str, Any]:
    """``worlds/fixed-wing.toml`` as a table with ``{"gnss.rate_hz": 2.0, ...}`` applied."""
    text = (files("worlds") / "fixed-wing.toml").read_text(encoding="utf-8")
    data = tomllib.loads(text)
    for dotted, value in overrides.items():
        *path, key = dotted.split(".")
        reduce(lambda table, k: table.setdefault(k, {}), path, data)[key] = value
    return data


def fw_world(**overrides: Any) -> FixedWingWorld:
    """The bundled world with ``overrides`` (dotted keys), validated."""
    return world_from_dict(fw_doc(**overrides), name="test-fixed-wing")


def short_world(**overrides: Any) -> FixedWingWorld:
    """The 30 s flight of :data:`SHORT_FLIGHT` with ``overrides``."""
    return fw_world(**{**SHORT_FLIGHT, **overrides})


#: A 20 s level flight with one left turn at 3-7 s, between GNSS fixes 10 s apart (0, 10,
#: 20 s): no fix falls in the turn.
TURN_BETWEEN_FIXES = {"duration_s": 20.0, "gnss.rate_hz": 0.1,
                      "flight.start_climb_deg": 0.0, "flight.start_speed_mps": 25.0,
                      "flight.manoeuvre_start_s": [3.0, 6.0], "flight.manoeuvre_ramp_s": [1.0, 1.0],
                      "flight.turn_rate_deg_s": [9.0, 0.0], "flight.climb_deg": [0.0, 0.0],
                      "flight.speed_mps": [25.0, 25.0]}


def turn_between_fixes(**overrides: Any) -> FixedWingWorld:
    """:data:`TURN_BETWEEN_FIXES` with ``overrides``, one run."""
    return fw_world(**{**TURN_BETWEEN_FIXES, "runs": 1, **overrides})
