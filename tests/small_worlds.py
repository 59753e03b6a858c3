"""Small in-code worlds for tests: built through the same validator as world files.

* :func:`small_world` - planar SLAM, a 30 m square loop among 4 landmarks;
* :func:`small_drone_doc` / :func:`small_drone_world` - the same loop flown by the drone
  over a hill;
* :func:`star_sensor_doc` / :func:`star_sensor_world` / :func:`short_star_sensor_world` -
  the bundled star-sensor world with overrides, and a shortened one.
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Mapping, Sequence
from importlib.resources import files
from typing import Any

from slam.kinds.planar.world import World
from slam.registry import world_from_dict

SQUARE_WAYPOINTS = [[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]
SQUARE_LANDMARKS = [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]]


SETTINGS: dict[str, Any] = {
    "unscented": {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"},
    "central_difference": {"h": 3.0**0.5},
}
"""The filter settings tables of the small worlds (the bundled SLAM worlds' own)."""


def small_world(
    *,
    runs: int = 3,
    seed: int = 0,
    filters: Sequence[str] = ("ekf",),
    landmarks: Sequence[Sequence[float]] = SQUARE_LANDMARKS,
    waypoints: Sequence[Sequence[float]] = SQUARE_WAYPOINTS,
    vehicle: Mapping[str, Any] | None = None,
    sensor: Mapping[str, Any] | None = None,
    noise: Mapping[str, Any] | None = None,
    filter_options: Mapping[str, Any] | None = None,
    name: str = "small",
) -> World:
    """A 30 m square loop (counter-clockwise from the origin, heading 0) among 4 landmarks.

    One lap is 120 m (1 600 steps at Bailey's 3 m/s, 0.025 s). ``vehicle``, ``sensor``,
    ``noise`` and ``filter_options`` override keys of those sections in file units
    (``{"loops": 2, "initial_sigma_heading_deg": 1.0}``); everything else is Bailey's default.
    """
    data: dict[str, Any] = {
        "kind": "planar-slam",
        "description": "Test world: 30 m square loop, 4 landmarks",
        "runs": runs,
        "seed": seed,
        "map": {
            "bounds_m": [-20.0, 50.0, -20.0, 50.0],
            "landmarks": [list(map(float, p)) for p in landmarks],
            "waypoints": [list(map(float, p)) for p in waypoints],
        },
        "vehicle": {
            "loops": 1,
            "start_xy_m": [0.0, 0.0],
            "start_heading_deg": 0.0,
            **(vehicle or {}),
        },
        "sensor": dict(sensor or {}),
        "noise": dict(noise or {}),
        "filters": {"names": list(filters), **SETTINGS, **(filter_options or {})},
    }
    return world_from_dict(data, name=name)


DRONE_FILTERS = ("ekf", "srckf", "srukf", "srcdkf")


def small_drone_doc(**sections: Any) -> dict[str, Any]:
    """A 30 m square loop (counter-clockwise from the origin) among 4 landmarks, one hill.

    Each keyword replaces a top-level key; a dict for a section that is a table merges
    into it (``terrain={"hill_amplitude_m": 25.0}``).
    """
    doc: dict[str, Any] = {
        "kind": "drone-slam",
        "description": "Test world: 30 m square loop over a hill, 4 landmarks",
        "runs": 2,
        "seed": 0,
        "map": {"bounds_m": [-20.0, 50.0, -20.0, 50.0],
                "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]],
                "waypoints": [[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]},
        "terrain": {"type": "hills", "hill_centres_m": [[15.0, 15.0]], "hill_amplitude_m": 4.0,
                    "hill_width_m": 6.0, "grid_spacing_m": 3.0},
        "vehicle": {"loops": 1, "start_xy_m": [0.0, 0.0], "start_heading_deg": 0.0,
                    "speed_mps": 4.0},
        "filters": {"names": list(DRONE_FILTERS), **SETTINGS},
        "paper": {"filters": {"srckf": {"pos_err_range_m": {"x": [-0.5, 0.6],
                                                            "y": [-0.5, 0.2],
                                                            "z": [-0.5, 0.05]}}}},
    }
    for key, value in sections.items():
        if isinstance(value, dict) and isinstance(doc.get(key), dict):
            doc[key] = {**doc[key], **value}
        else:
            doc[key] = value
    return doc


def small_drone_world(**sections: Any):
    """:func:`small_drone_doc` validated as the world ``small-drone``."""
    return world_from_dict(small_drone_doc(**sections), name="small-drone")


def overridden(doc: dict[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of ``doc`` with dotted-key overrides (``{"gyro.rate_hz": 100.0}``)."""
    data = copy.deepcopy(doc)
    for dotted, value in overrides.items():
        *head, last = dotted.split(".")
        table = data
        for key in head:
            table = table.setdefault(key, {})
        table[last] = value
    return data


def star_sensor_doc(**overrides: Any) -> dict[str, Any]:
    """The bundled star-sensor document with dotted-key overrides (``"gyro.rate_hz"``)."""
    raw = (files("worlds") / "star-sensor.toml").read_bytes()
    return overridden(tomllib.loads(raw.decode("utf-8")), overrides)


def star_sensor_world(**overrides: Any):
    """:func:`star_sensor_doc` validated as the world ``test-attitude``."""
    return world_from_dict(star_sensor_doc(**overrides), name="test-attitude")


def short_star_sensor_world(duration: float = 60.0, **overrides: Any):
    """The star-sensor world cut to ``duration`` seconds (steady state from half of it)."""
    return star_sensor_world(**{"duration_s": duration,
                                "scoring.steady_state_from_s": duration / 2, **overrides})
