"""Bundled world files (TOML), how to read them, and the schema engine that the scenario
kinds (:mod:`slam.kinds`) validate them with.

>>> from slam.kinds import load_world
>>> world = load_world("bailey")
"""

from worlds.loader import WorldDocument, bundled_names, read_world
from worlds.schema import WorldError

__all__ = ["WorldDocument", "WorldError", "bundled_names", "read_world"]
