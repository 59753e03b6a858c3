"""A small TOML writer for mutated world documents (``tomllib`` only reads).

It writes what ``tomllib`` returns - tables, arrays, strings, integers, floats (``nan``,
``inf`` included), booleans, dates and times - so a mutated document can be any value a
hostile user could type, including the ones the schema must refuse.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import re
from typing import Any

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def key(name: str) -> str:
    """A TOML key: bare when it can be, else a quoted basic string."""
    return name if _BARE.fullmatch(name) else string(name)  # ($ would allow a final \n)


def string(text: str) -> str:
    """A TOML basic string (control characters escaped)."""
    out = json.dumps(text, ensure_ascii=False)
    return out.replace("\x7f", "\\u007F")


def value(v: Any) -> str:
    """One TOML value, inline (tables become inline tables)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = repr(v)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(v, str):
        return string(v)
    if isinstance(v, dt.datetime | dt.date | dt.time):
        return v.isoformat()
    if isinstance(v, list | tuple):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{key(k)} = {value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def dumps(doc: dict[str, Any]) -> str:
    """A whole document: scalars and arrays first, then ``[section]`` headers, nested."""
    lines: list[str] = []
    _table(doc, (), lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _table(doc: dict[str, Any], path: tuple[str, ...], lines: list[str]) -> None:
    subtables = {k: v for k, v in doc.items() if isinstance(v, dict)}
    plain = {k: v for k, v in doc.items() if not isinstance(v, dict)}
    if path and (plain or not subtables):
        lines.append("")
        lines.append("[" + ".".join(key(p) for p in path) + "]")
    for k, v in plain.items():
        lines.append(f"{key(k)} = {value(v)}")
    for k, v in subtables.items():
        _table(v, (*path, k), lines)
