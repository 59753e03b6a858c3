"""Alignment test worlds (not a test module): the bundled ``alignment`` document with
dotted-key overrides, validated through the kind's schema."""

from __future__ import annotations

import tomllib
from functools import reduce
from importlib.resources import files
from typing import Any

from slam.kinds.alignment.world import AlignmentWorld
from slam.registry import world_from_dict


def alignment_doc(**overrides: Any) -> dict[str, Any]:
    """``worlds/alignment.toml`` as a table, ``{"imu.rate_hz": 500.0, ...}`` applied."""
    data = tomllib.loads((files("worlds") / "alignment.toml").read_text(encoding="utf-8"))
    for dotted, value in overrides.items():
        *path, key = dotted.split(".")
        reduce(lambda table, k: table.setdefault(k, {}), path, data)[key] = value
    return data


def alignment_world(duration_s: float = 5.0, **overrides: Any) -> AlignmentWorld:
    """The bundled world cut to ``duration_s`` (its ranking scored over the second half)."""
    return world_from_dict(alignment_doc(**{"duration_s": duration_s,
                                            "scoring.settled_from_s": duration_s / 2,
                                            **overrides}), name="test-alignment")


NO_ERRORS = {f"imu.{k}": 0.0 for k in (
    "gyro_bias_deg_s", "gyro_white_deg_s", "gyro_markov_deg_s", "accel_bias_g",
    "accel_white_g", "accel_markov_g")}
"""Overrides for an error-free IMU."""

CALM = {"wind.compliance_m_per_mps": 0.0}
"""No wind motion."""

STILL = {"sway.elevation_amplitude_deg": 0.0, "sway.roll_amplitude_deg": 0.0}
"""No sway."""
