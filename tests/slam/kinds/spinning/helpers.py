"""Small ``spinning`` worlds for the tests: the bundled document with overrides, validated
through the kind's schema (the kind is registered here, as a plug-in would be)."""

from __future__ import annotations

import copy
from typing import Any

from slam.kinds.spinning import KIND
from slam.registry import register, world_from_dict
from worlds.loader import read_world

register(KIND)

#: A cheap world: 1 s epochs (88 instead of 871), a one-cell sweep with one γ.
TINY = {"sample_interval_s": 1.0, "runs": 2, "sweep.factors": [2.0], "sweep.gammas_rad": [2.0],
        "sweep.scales": ["both"],
        "sweep.runs_per_cell": 1, "sweep.filters": ["srckf", "ekf", "srchinf"]}


def _put(table: dict[str, Any], path: list[str], value: Any) -> None:
    if len(path) == 1 and value is None:
        table.pop(path[0], None)  # None removes the key
    elif len(path) == 1:
        table[path[0]] = value
    else:
        _put(table.setdefault(path[0], {}), path[1:], value)


def spinning_doc(**overrides: Any) -> dict[str, Any]:
    """The bundled ``spinning`` document with dotted-key overrides (``"flight.crosswind_mps"``;
    a value ``None`` removes the key)."""
    data = copy.deepcopy(read_world("spinning").data)
    for dotted, value in overrides.items():
        _put(data, dotted.split("."), value)
    return data


def spinning_world(**overrides: Any):
    """:func:`spinning_doc` validated as the world ``test-spinning``."""
    return world_from_dict(spinning_doc(**overrides), name="test-spinning")


def tiny_world(**overrides: Any):
    """:data:`TINY` plus ``overrides``."""
    return spinning_world(**{**TINY, **overrides})
