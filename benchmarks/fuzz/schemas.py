"""What the kinds' world schemas say about their keys, for the schema-driven families.

Each kind's ``slam/kinds/<kind>/world.py`` declares its keys as a table of
:mod:`worlds.schema` fields (``SCHEMA``); :func:`numeric_keys` walks that table and
returns every numeric key (number, integer, fixed-length vector or list of numbers) with
its allowed interval, so a family can find "every σ or noise density of this kind" or
"every rate and duration" by the key's name and push it to a value the schema allows.
Only the schema tables are read (no kind is run here); a kind added later is found the
same way, and a key a kind's own field class declares without an interval is found by its
value in the bundled world instead (:func:`doc_numeric_paths`).
"""

from __future__ import annotations

import importlib
import math
import pkgutil
import re
from dataclasses import dataclass
from functools import cache
from typing import Any

from .core import KeyPath, get, is_num, walk


@dataclass(frozen=True)
class KeySpec:
    """One numeric key of a kind's schema: its path, shape and allowed interval.

    ``shape`` is ``"number"``, ``"integer"``, ``"vector"`` (``length`` numbers) or
    ``"list"`` (any length); ``lo``/``hi`` and their openness are the schema's interval
    in file units (``None`` when the field declares none).
    """

    path: tuple[str, ...]
    shape: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    length: int | None = None

    @property
    def name(self) -> str:
        """The key's own (last) name."""
        return self.path[-1]

    def allows(self, v: float) -> bool:
        """``v`` is inside the schema's interval (``True`` when it declares none)."""
        if self.lo is None or self.hi is None:
            return True
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        return bool(above and below)


def _spec(path: tuple[str, ...], field: Any) -> KeySpec | None:
    """The :class:`KeySpec` of a schema field, or ``None`` for a non-numeric one."""
    from worlds import schema as ws

    iv = getattr(field, "interval", None)
    bounds: dict[str, Any] = {}
    if isinstance(iv, ws.Interval):
        bounds = {"lo": iv.lo, "hi": iv.hi, "lo_open": iv.lo_open, "hi_open": iv.hi_open}
    if isinstance(field, ws.Integer):
        return KeySpec(path, "integer", **bounds)
    if isinstance(field, ws.Vector):
        return KeySpec(path, "vector", length=field.length, **bounds)
    if isinstance(field, ws.Number):
        return KeySpec(path, "number", **bounds)
    if bounds:  # a kind's own list-of-numbers field (fixed-wing's NumberList)
        return KeySpec(path, "list", **bounds)
    return None


def _walk_schema(schema: Any, path: tuple[str, ...] = ()) -> list[KeySpec]:
    from worlds import common as wc
    from worlds import schema as ws

    out: list[KeySpec] = []
    for key, spec in schema.items():
        if isinstance(spec, ws.Section):
            out.extend(_walk_schema(spec.schema, (*path, key)))
        elif isinstance(spec, wc.SettingsTable):  # [filters.<table>]: an optional table
            out.extend(_walk_schema(wc.RULE_SETTINGS[spec.table], (*path, key)))
        else:
            found = _spec((*path, key), spec)
            if found is not None:
                out.append(found)
    return out


@cache
def kind_schemas() -> dict[str, Any]:
    """World kind name -> its schema table, from every ``slam/kinds/*/world.py`` that
    declares ``KIND`` and ``SCHEMA``."""
    import slam.kinds

    out: dict[str, Any] = {}
    for info in pkgutil.iter_modules(slam.kinds.__path__):
        try:
            mod = importlib.import_module(f"slam.kinds.{info.name}.world")
        except ImportError:
            continue
        kind, schema = getattr(mod, "KIND", None), getattr(mod, "SCHEMA", None)
        if isinstance(kind, str) and isinstance(schema, dict):
            out[kind] = schema
    return out


@cache
def numeric_keys(kind: str) -> tuple[KeySpec, ...]:
    """Every numeric key the ``kind``'s schema declares (empty for an unknown kind)."""
    schema = kind_schemas().get(kind)
    return tuple(_walk_schema(schema)) if schema is not None else ()


NOISE = re.compile(r"sigma|noise|_var|var_|white|arw|vrw|_rw|markov_(?!tau)|density|gamma")
"""Names of σ, variance, noise-density and H∞-bound keys (not a Markov time constant)."""
SIZE_UP = re.compile(r"(^|_)rate_hz$|duration_s$|flight_time_s$|^runs_per_cell$|^loops$"
                     r"|^n_stars$")
"""Keys whose larger values mean more samples, epochs or runs."""
SIZE_DOWN = re.compile(r"interval_s$|^dt_s$")
"""Keys whose smaller values mean more samples (a sample period)."""


def noise_keys(kind: str) -> list[KeySpec]:
    """The ``kind``'s σ / noise keys that allow a value as small as 1e-300."""
    return [k for k in numeric_keys(kind) if NOISE.search(k.name) and k.allows(1e-300)]


def size_keys(kind: str) -> list[tuple[KeySpec, float]]:
    """The ``kind``'s size keys, each with its most expensive allowed value (the upper
    end for rates and durations, the lower end for sample periods; finite ends only)."""
    out = []
    for k in numeric_keys(kind):
        if k.lo is None or k.hi is None:
            continue
        if SIZE_UP.search(k.name) and math.isfinite(k.hi) and not k.hi_open:
            out.append((k, k.hi))
        elif SIZE_DOWN.search(k.name) and not k.lo_open and k.lo > 0:
            out.append((k, k.lo))
    return out


def doc_numeric_paths(doc: dict[str, Any], pattern: re.Pattern[str]) -> list[KeyPath]:
    """Paths (outside ``[paper]``) of numbers and lists of numbers in a world document
    whose key name matches ``pattern``."""
    out: list[KeyPath] = []
    for p in walk(doc, items=False):
        if p[0] == "paper" or not isinstance(p[-1], str) or not pattern.search(p[-1]):
            continue
        v = get(doc, p)
        if is_num(v) or (isinstance(v, list) and v and all(is_num(x) for x in v)):
            out.append(p)
    return out
