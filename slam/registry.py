"""The registry of scenario kinds, and loading worlds through it.

Every kind is a folder under ``slam/kinds/`` exporting one :class:`~slam.kind.Kind`;
the built-in kinds are registered here, in one place (kinds never import this module).
A kind defined elsewhere (a plug-in, a test) calls :func:`register` itself.  The command
line, the campaign runner and the report writer look kinds up here and nowhere else.
"""

from __future__ import annotations

import os
from typing import Any

from slam.kind import Kind
from slam.kinds import alignment, attitude, drone, fixed_wing, planar, recorded, ship, spinning
from worlds.loader import WorldDocument, bundled_documents, check_nesting, read_world
from worlds.schema import WorldError

KINDS: dict[str, Kind] = {}
"""World kind name -> kind."""


def register(kind: Kind) -> Kind:
    """Add ``kind`` to the registry (replacing one of the same name) and return it."""
    KINDS[kind.name] = kind
    return kind


for _k in (planar.KIND, drone.KIND, attitude.KIND, recorded.KIND, ship.KIND, spinning.KIND,
           alignment.KIND, fixed_wing.KIND):
    register(_k)


def get_kind(name: str) -> Kind:
    """The registered kind called ``name`` (``KeyError`` if none)."""
    return KINDS[name]


def log_kind() -> Kind:
    """The kind that reads recorded logs (``slam run --log``)."""
    return next(k for k in KINDS.values() if k.open_log is not None)


def _world_kind(data: Any, source: str) -> Kind:
    if not isinstance(data, dict):
        raise WorldError(source, None, "a world must be a table")
    kind = data.get("kind")
    known = ", ".join(k for k, v in KINDS.items() if v.open_log is None)
    if kind is None:
        raise WorldError(source, "kind", f"missing (required; one of: {known})")
    if not isinstance(kind, str) or kind not in KINDS:
        raise WorldError(source, "kind", f"unknown kind; known: {known}", kind)
    return KINDS[kind]


def world_from_dict(data: dict[str, Any], name: str = "custom", source: str | None = None,
                    base: Any = None) -> Any:
    """Validate a parsed world document (as ``tomllib`` returns it) with its kind's schema.

    ``base`` is the folder that relative map files are read from (``None``: none allowed).
    """
    source = source or f"<{name}>"
    check_nesting(data, source)
    return _world_kind(data, source).parse(data, name, source, base)


def world_from_document(doc: WorldDocument) -> Any:
    """Validate a read world file."""
    return world_from_dict(doc.data, doc.name, doc.source, doc.base)


def load_world(name_or_path: str | os.PathLike[str]) -> Any:
    """Load and validate a bundled world (by file stem) or a world file (by path).

    Raises :class:`~worlds.schema.WorldError` naming the file, the dotted key and the rule.
    """
    return world_from_document(read_world(name_or_path))


def list_worlds() -> list[tuple[str, str, str]]:
    """The bundled worlds as ``(name, kind, one-line description)``, sorted by name.

    Only ``kind`` and ``description`` are read here; :func:`load_world` does the full check.
    """
    return [(d.name, str(d.data.get("kind", "?")), str(d.data.get("description", "")))
            for d in bundled_documents()]
