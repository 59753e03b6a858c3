"""The registry of scenario kinds, and loading worlds through it.

Every kind is a folder under ``slam/kinds/`` exporting one :class:`~slam.kind.Kind`;
the built-in kinds are registered here, in one place (kinds never import this module).
A kind defined elsewhere (a plug-in, a test) calls :func:`register` itself.  The command
line, the campaign runner and the report writer look kinds up here and nowhere else.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import worlds.schema as ws
from slam.kind import Kind
from slam.kinds import (
    alignment,
    attitude,
    attitude_log,
    drone,
    fixed_wing,
    ins_log,
    planar,
    recorded,
    ship,
    spinning,
)
from worlds import limits
from worlds.loader import WorldDocument, bundled_documents, check_nesting, read_world
from worlds.schema import WorldError

KINDS: dict[str, Kind] = {}
"""World kind name -> kind."""


def register(kind: Kind) -> Kind:
    """Add ``kind`` to the registry (replacing one of the same name) and return it.

    A kind must declare what a run of its worlds costs (``Kind.work``, a function of the
    world): ``TypeError`` otherwise."""
    if not isinstance(kind, Kind):
        raise TypeError(f"register() takes a slam.kind.Kind, not {type(kind).__name__}")
    if not callable(getattr(kind, "work", None)):
        raise TypeError(f"kind {kind.name!r} declares no work (Kind.work: world -> the "
                        "sizes of one run, checked against worlds.limits)")
    KINDS[kind.name] = kind
    return kind


for _k in (planar.KIND, drone.KIND, attitude.KIND, recorded.KIND, ship.KIND, spinning.KIND,
           alignment.KIND, fixed_wing.KIND, attitude_log.KIND, ins_log.KIND):
    register(_k)

PLUGIN_KINDS = "navfilters.kinds"
"""The entry-point group of installed packages' kinds: each names a :class:`Kind`."""


def load_plugins() -> list[str]:
    """Register every installed plug-in kind (:data:`PLUGIN_KINDS`); one that fails to
    import, is not a Kind or reuses a registered name is skipped with a one-line warning
    on stderr (a broken plug-in never stops ``slam``).  -> the names registered."""
    import sys
    from importlib.metadata import entry_points

    done = []
    for ep in sorted(entry_points(group=PLUGIN_KINDS), key=lambda e: e.name):
        try:
            kind = ep.load()
            if not isinstance(kind, Kind):
                raise TypeError(f"{ep.value} is a {type(kind).__name__}, not a slam.kind.Kind")
            if kind.name in KINDS:
                raise ValueError(f"kind {kind.name!r} is already registered")
            register(kind)
            done.append(kind.name)
        except Exception as exc:  # noqa: BLE001  (any fault of someone else's package)
            print(f"warning: plug-in kind {ep.name} ({ep.value}) not loaded: "
                  f"{type(exc).__name__}: {exc}", file=sys.stderr)
    return done


load_plugins()


def get_kind(name: str) -> Kind:
    """The registered kind called ``name`` (``KeyError`` if none)."""
    return KINDS[name]


def log_kind(path: str | os.PathLike[str] | None = None) -> Kind:
    """The kind that reads the recorded log ``path`` (``slam run --log``): the IMU + GNSS
    log kind for ``kitti``, a ``.csv`` or a folder of the KITTI files
    (:func:`slam.kinds.ins_log.reads`), else the planar-log kind (also without ``path``)."""
    if path is not None and ins_log.reads(path):
        return KINDS[ins_log.KIND.name]
    return KINDS[recorded.KIND.name]


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
    kind = _world_kind(data, source)
    world = kind.parse(data, name, source, base)
    check_work(world, data)
    return world


def check_work(world: Any, data: dict[str, Any] | None = None) -> None:
    """Refuse ``world`` if one run of it would cost more than :mod:`worlds.limits`
    allows: the one place every kind's work (``Kind.work``) is checked, before anything
    is simulated.  The :class:`~worlds.schema.WorldError` names the world's source, the
    key that drives the size (shown with its value in ``data``, the file's table, when
    the file gives one) and both figures."""
    def error(size: limits.Size, message: str) -> WorldError:
        value = ws.NO_VALUE
        if size.key is not None and data is not None:
            try:
                given = ws.value_at(data, size.key)
            except (KeyError, TypeError):
                given = ws.NO_VALUE
            if isinstance(given, str | int | float):  # not a list of landmarks
                value = given
        return WorldError(world.source, size.key, message, value)

    limits.check_work(get_kind(world.kind).work(world), world.kind, error)


def open_log(path: Path, filters: Any = None, mode: str | None = None,
             kind: Kind | None = None, **options: Any) -> Any:
    """A recorded log as a one-run world of ``kind`` (default: the log kind that reads
    ``path``, :func:`log_kind`; ``slam run --log FILE``), its work checked like a world's
    (raises the kind's ``LogFormatError`` or a :class:`~worlds.schema.WorldError` naming
    the file); ``options`` go to the kind's reader (the IMU + GNSS log's holdout and
    outages)."""
    world = (kind or log_kind(path)).open_log(Path(path), filters, mode, **options)
    check_work(world)
    return world


def world_from_document(doc: WorldDocument) -> Any:
    """Validate a read world file."""
    return world_from_dict(doc.data, doc.name, doc.source, doc.base)


def load_world(name_or_path: str | os.PathLike[str]) -> Any:
    """Load and validate a bundled world (by file stem) or a world file (by path).

    Raises :class:`~worlds.schema.WorldError` naming the file, the dotted key and the rule.
    """
    return world_from_document(read_world(name_or_path))


def list_worlds() -> list[tuple[str, str, str]]:
    """The bundled worlds and the installed plug-ins' as ``(name, kind, one-line
    description)``, sorted by name.

    Only ``kind`` and ``description`` are read here; :func:`load_world` does the full check.
    """
    return [(d.name, str(d.data.get("kind", "?")), str(d.data.get("description", "")))
            for d in bundled_documents(plugins=True)]
