"""Find, read and validate world files.

``load_world("bailey")`` reads the bundled ``worlds/bailey.toml``; ``load_world("my/w.toml")``
(anything with a path separator or a ``.toml`` suffix, or a ``Path``) reads that file.
The document's ``kind`` picks the schema: each kind registers a parser in :data:`PARSERS`
taking ``(data, name, source, base)`` and returning its world dataclass.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections.abc import Callable
from importlib.resources import files
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from worlds import attitude, drone, planar
from worlds.planar import World
from worlds.schema import WorldError

Parser = Callable[[dict[str, Any], str, str, "Traversable | None"], Any]

PARSERS: dict[str, Parser] = {planar.KIND: planar.parse, attitude.KIND: attitude.parse,
                              drone.KIND: drone.parse}
"""World kind -> parser."""

_LINE = re.compile(r"at line (\d+)")


def _package() -> Traversable:
    return files("worlds")


def _bundled_names() -> list[str]:
    return sorted(p.name[:-5] for p in _package().iterdir() if p.name.endswith(".toml"))


def _parse_toml(raw: bytes, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise WorldError(source, None, f"not UTF-8 text: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        match = _LINE.search(str(exc))
        line = int(match.group(1)) if match else None
        raise WorldError(source, None, f"invalid TOML: {exc}", line=line) from None


def _locate(name_or_path: str | os.PathLike[str]) -> tuple[str, str, Traversable]:
    """-> (world name, file name shown in errors, the .toml file)."""
    text = os.fspath(name_or_path)
    looks_like_path = (
        isinstance(name_or_path, os.PathLike)
        or text.endswith(".toml")
        or os.sep in text
        or "/" in text
    )
    if looks_like_path:
        path = Path(text)
        if not path.is_file():
            raise WorldError(text, None, "no such world file")
        return path.stem, text, path
    candidate = _package() / f"{text}.toml"
    if not candidate.is_file():
        known = ", ".join(_bundled_names())
        raise WorldError(text, None, f"no bundled world of that name (bundled: {known})")
    return text, f"worlds/{text}.toml", candidate


def world_from_dict(
    data: dict[str, Any],
    name: str = "custom",
    source: str | None = None,
    base: Traversable | None = None,
) -> Any:
    """Validate a parsed world document (as ``tomllib`` returns it) and build the world.

    ``base`` is the folder that relative map files are read from (``None``: none allowed).
    """
    source = source or f"<{name}>"
    if not isinstance(data, dict):
        raise WorldError(source, None, "a world must be a table")
    kind = data.get("kind")
    if kind is None:
        raise WorldError(source, "kind", f"missing (required; one of: {', '.join(PARSERS)})")
    if kind not in PARSERS:
        raise WorldError(source, "kind", f"unknown kind; known: {', '.join(PARSERS)}", kind)
    return PARSERS[kind](data, name, source, base)


def load_world(name_or_path: str | os.PathLike[str]) -> World:
    """Load and validate a bundled world (by file stem) or a world file (by path).

    Raises :class:`WorldError` naming the file, the dotted key and the rule broken.
    """
    name, source, file = _locate(name_or_path)
    try:
        raw = file.read_bytes()
    except OSError as exc:
        raise WorldError(source, None, f"cannot read: {exc}") from None
    base = file.parent if isinstance(file, Path) else _package()
    return world_from_dict(_parse_toml(raw, source), name, source, base)


def list_worlds() -> list[tuple[str, str, str]]:
    """The bundled worlds as ``(name, kind, one-line description)``, sorted by name.

    Only ``kind`` and ``description`` are read here; :func:`load_world` does the full check.
    """
    out = []
    for name in _bundled_names():
        source = f"worlds/{name}.toml"
        data = _parse_toml((_package() / f"{name}.toml").read_bytes(), source)
        out.append((name, str(data.get("kind", "?")), str(data.get("description", ""))))
    return out
