"""The world-file reference of every registered kind, as one Markdown page.

For each kind with a world schema (its ``world`` module's ``SCHEMA``) the page has one
table of every key (:func:`worlds.reference.rows`: unit, type, allowed range, default,
meaning from the kind's ``keys`` module), then the filter names each kind accepts and
the settings tables.  The docs build writes it (``docs/conf.py``); nothing in it is
written by hand.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import worlds.common as wc
import worlds.reference as wr
from estimators.filters import FILTER_NAMES, ROBUST_FILTER_NAMES, SETTINGS
from slam.registry import KINDS


@dataclass(frozen=True)
class KindSchema:
    """A kind's world schema and the meanings of its keys."""

    kind: str
    schema: Mapping[str, Any]
    descriptions: Mapping[str, str]
    module: str


def _world_module(kind: Any) -> ModuleType:
    return sys.modules[kind.parse.__module__]


def kind_schemas() -> list[KindSchema]:
    """Every registered kind that reads world files, with its schema and key meanings
    (a kind without a ``keys`` module has none: every key then counts as missing)."""
    out = []
    for kind in KINDS.values():
        world = _world_module(kind)
        schema = getattr(world, "SCHEMA", None)
        if schema is None:  # a recorded log is not a world file
            continue
        package = world.__name__.rpartition(".")[0]
        try:
            keys = importlib.import_module(f"{package}.keys")
        except ModuleNotFoundError:
            descriptions: Mapping[str, str] = {}
        else:
            descriptions = keys.DESCRIPTIONS
        out.append(KindSchema(kind.name, schema, descriptions, world.__name__))
    return out


def filter_table() -> str:
    """The :func:`estimators.make_filter` names: their settings, the settings tables a
    world states for them, and the kinds that run them."""
    lines = ["| filter | settings | world table | kinds |", "|---|---|---|---|"]
    for name in FILTER_NAMES + ROBUST_FILTER_NAMES:
        kinds = [k.name for k in KINDS.values() if name in k.filters]
        tables = ", ".join(f"`[filters.{t}]`" for t in wc.tables_of(name)) or "—"
        lines.append(f"| `{name}` | {', '.join(SETTINGS[name]) or '—'} | {tables} | "
                     f"{', '.join(kinds) or '—'} |")
    return "\n".join(lines) + "\n"


def workbench_names() -> str:
    """The names each kind accepts beyond :func:`estimators.make_filter`'s (variants,
    prefixed filters)."""
    base = set(FILTER_NAMES + ROBUST_FILTER_NAMES)
    lines = []
    for kind in KINDS.values():
        extra = [n for n in kind.filters if n not in base]
        if extra:
            lines.append(f"- **{kind.name}**: " + ", ".join(f"`{n}`" for n in extra))
    return "\n".join(lines) + "\n"


def markdown() -> str:
    """The whole reference page."""
    parts = [
        "# World-file reference\n",
        "Generated from the schema declarations (`worlds/schema.py`, `worlds/common.py` and "
        "each kind's `world.py`) and the key meanings beside them (each kind's `keys.py`) "
        "when the docs are built. A unit is read off the key's name; angles are degrees "
        "in the file and radians in the code. *required in its section*: the key must be "
        "given whenever its (optional) section is.\n",
    ]
    for ks in kind_schemas():
        parts.append(f"## `{ks.kind}`\n")
        parts.append(f"Declared in `{ks.module}`.\n")
        parts.append(wr.table(wr.rows(ks.schema, ks.descriptions)))
    parts.append("## Filter settings tables\n")
    parts.append("A `[filters.<table>]` table states every key of it; which tables a world "
                 "needs follows from the filters it runs (a missing one is an error naming "
                 "the filters that need it).\n")
    parts.append(wr.table(wr.settings_rows()))
    parts.append("## Filter names\n")
    parts.append(filter_table())
    parts.append("\nWorkbench names some kinds accept beyond these:\n\n")
    parts.append(workbench_names())
    return "\n".join(parts)
