"""Bundled world files (TOML) and the loader/validator for them.

>>> from worlds import load_world
>>> world = load_world("bailey")
"""

from worlds.loader import PARSERS, list_worlds, load_world, world_from_dict
from worlds.planar import (
    ControlNoise,
    FilterSpec,
    MapSpec,
    RangeBearingSpec,
    VehicleSpec,
    World,
)
from worlds.schema import WorldError

__all__ = [
    "PARSERS",
    "ControlNoise",
    "FilterSpec",
    "MapSpec",
    "RangeBearingSpec",
    "VehicleSpec",
    "World",
    "WorldError",
    "list_worlds",
    "load_world",
    "world_from_dict",
]
