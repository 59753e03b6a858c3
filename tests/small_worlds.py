"""Small in-code worlds for tests: built through the same validator as world files."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from slam.kinds import world_from_dict
from slam.kinds.planar.world import World

SQUARE_WAYPOINTS = [[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]
SQUARE_LANDMARKS = [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]]


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
        "filters": {"names": list(filters), **(filter_options or {})},
    }
    return world_from_dict(data, name=name)
