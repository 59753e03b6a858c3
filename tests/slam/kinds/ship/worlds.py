"""Ship test worlds (not a test module): the bundled ``ship`` document with dotted-key
overrides, validated through the kind's schema.  Importing this module registers the
``ship`` kind (the built-in registry does not list it yet)."""

from __future__ import annotations

import tomllib
from functools import reduce
from importlib.resources import files
from typing import Any

from slam.kinds.ship import KIND
from slam.kinds.ship.world import ShipWorld
from slam.registry import register, world_from_dict

register(KIND)


def ship_doc(**overrides: Any) -> dict[str, Any]:
    """``worlds/ship.toml`` as a table, ``{"gyro.rate_hz": 50.0, ...}`` applied."""
    data = tomllib.loads((files("worlds") / "ship.toml").read_text(encoding="utf-8"))
    for dotted, value in overrides.items():
        *path, key = dotted.split(".")
        reduce(lambda table, k: table.setdefault(k, {}), path, data)[key] = value
    return data


def ship_world(duration_s: float = 300.0, **overrides: Any) -> ShipWorld:
    """The bundled world, cut to ``duration_s`` (steady state from its last third)."""
    doc = ship_doc(**{"duration_s": duration_s,
                      "scoring.steady_state_from_s": duration_s * 2.0 / 3.0, **overrides})
    return world_from_dict(doc, name="test-ship")


def noise_free(**overrides: Any) -> dict[str, Any]:
    """Overrides for a gyro without noise or drift (the vectors stay noisy)."""
    return {"gyro.arw_deg_sqrt_h": 0.0, "gyro.bias_rw_deg_h_sqrt_h": 0.0,
            "gyro.bias_deg_h": [0.0, 0.0, 0.0], **overrides}
