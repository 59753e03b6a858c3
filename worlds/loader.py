"""Find and read world files.

``read_world("bailey")`` reads the bundled ``worlds/bailey.toml``; ``read_world("my/w.toml")``
(anything with a path separator or a ``.toml`` suffix, or a ``Path``) reads that file.
Validation against a kind's schema is the kind's (see :mod:`slam.kinds`): this module
only locates the file and parses its TOML.
"""

from __future__ import annotations

import functools
import os
import re
import tomllib
from dataclasses import dataclass
from importlib.metadata import entry_points
from importlib.resources import files
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

import worlds.limits as limits
from worlds.schema import WorldError, did_you_mean

_LINE = re.compile(r"at line (\d+)")
_STRING_OR_COMMENT = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:[^"\\\n]|\\.)*"|'
                                r"'[^'\n]*'|#[^\n]*")
_SEP = r"=\[\]{},\n"
_LONG_KEY = re.compile(rf"(?<![^{_SEP}])[^{_SEP}.]*(?:\.[^{_SEP}.]*){{{limits.MAX_NESTING},}}")
"""A run of more than :data:`~worlds.limits.MAX_NESTING` dot-separated parts between two
separators (``=``, brackets, braces, commas, line ends), matched only from a separator:
one pass over the text."""


@dataclass(frozen=True)
class WorldDocument:
    """A parsed world file: the TOML table, the world's name, the file name shown in
    errors, and the folder that relative map/mesh files are read from."""

    data: dict[str, Any]
    name: str
    source: str
    base: Traversable | None


def _package() -> Traversable:
    return files("worlds")


def bundled_names() -> list[str]:
    """The bundled worlds' names (file stems), sorted."""
    return sorted(p.name[:-5] for p in _package().iterdir() if p.name.endswith(".toml"))


PLUGIN_WORLDS = "navfilters.worlds"
"""The entry-point group of installed packages' world folders: each entry point names a
package whose ``*.toml`` files are worlds (a name the bundled worlds already use is
skipped)."""


@functools.cache
def plugin_worlds() -> dict[str, Traversable]:
    """The installed plug-ins' worlds by name (:data:`PLUGIN_WORLDS`); a folder that cannot
    be read is skipped."""
    bundled = set(bundled_names())
    out: dict[str, Traversable] = {}
    for ep in sorted(entry_points(group=PLUGIN_WORLDS), key=lambda e: e.name):
        try:
            folder = files(ep.value)
            found = sorted((p.name[:-5], p) for p in folder.iterdir()
                           if p.name.endswith(".toml"))
        except (ImportError, OSError, TypeError, ValueError):
            continue
        for name, p in found:
            if name not in bundled:
                out.setdefault(name, p)
    return out


def world_names() -> list[str]:
    """The bundled worlds' and the installed plug-ins' world names, sorted."""
    return sorted({*bundled_names(), *plugin_worlds()})


def check_key_parts(text: str, source: str) -> None:
    """Refuse a dotted key or table header of more than :data:`~worlds.limits.MAX_NESTING`
    parts before the text is parsed: ``tomllib``'s time and memory grow with the square of
    a dotted key's parts (a 200 KB key of 30 000 parts: about 4 GB), and the tables such a
    key makes would be refused for nesting anyway.  Strings and comments are skipped (a
    description may hold any number of dots); a pass of two regular expressions."""
    if text.count(".") < limits.MAX_NESTING:
        return
    bare = _STRING_OR_COMMENT.sub(lambda m: "S" + "\n" * m[0].count("\n"), text)
    if (m := _LONG_KEY.search(bare)) is not None:
        line = bare.count("\n", 0, m.start()) + 1
        parts = m[0].count(".") + 1
        raise WorldError(source, None, f"a dotted key or table header of {limits.count(parts)} "
                         f"parts; at most {limits.MAX_NESTING} are allowed (tables nest at "
                         f"most {limits.MAX_NESTING} levels)", line=line)


def parse_toml(raw: bytes, source: str) -> dict[str, Any]:
    """TOML text -> table; errors name the file (and line).  Values nested deeper than
    :data:`~worlds.limits.MAX_NESTING` levels, and dotted keys of more parts, are refused
    (the latter before parsing: :func:`check_key_parts`)."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise WorldError(source, None, f"not UTF-8 text: {exc}") from None
    check_key_parts(text, source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        match = _LINE.search(str(exc))
        line = int(match.group(1)) if match else None
        raise WorldError(source, None, f"invalid TOML: {exc}", line=line) from None
    except RecursionError:
        raise WorldError(source, None, "invalid TOML: arrays or tables nested too deeply "
                         f"(at most {limits.MAX_NESTING} levels)") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise WorldError(source, None, f"invalid TOML: {exc}") from None
    check_nesting(data, source)
    return data


def check_nesting(data: Any, source: str) -> None:
    """Refuse tables and arrays nested deeper than :data:`~worlds.limits.MAX_NESTING`."""
    if limits.depth(data) > limits.MAX_NESTING:
        raise WorldError(source, None, "arrays or tables nested deeper than "
                         f"{limits.MAX_NESTING} levels")


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
        if not path.exists():
            raise WorldError(text, None, "no such world file")
        limits.check_file(path, lambda why: WorldError(text, None, why))
        return path.stem, text, path
    candidate = _package() / f"{text}.toml"
    if not candidate.is_file():
        plugin = plugin_worlds().get(text)
        if plugin is not None:
            return text, f"{text}.toml (plug-in)", plugin
        names = world_names()
        raise WorldError(text, None, f"no bundled world of that name{did_you_mean(text, names)}"
                         f" (bundled: {', '.join(names)})")
    return text, f"worlds/{text}.toml", candidate


def read_world(name_or_path: str | os.PathLike[str]) -> WorldDocument:
    """Read a bundled world (by file stem) or a world file (by path) as a document."""
    name, source, file = _locate(name_or_path)
    try:
        raw = file.read_bytes()
    except OSError as exc:
        raise WorldError(source, None, f"cannot read: {exc}") from None
    base = (file.parent if isinstance(file, Path) else
            _package() if name not in plugin_worlds() else plugin_worlds()[name].parent)
    return WorldDocument(parse_toml(raw, source), name, source, base)


def bundled_documents(plugins: bool = False) -> list[WorldDocument]:
    """Every bundled world's document (with ``plugins`` the installed plug-ins' too),
    sorted by name."""
    return [read_world(name) for name in (world_names() if plugins else bundled_names())]
