"""A world file's errors: :class:`WorldError` (file, dotted key, value, rule) and how
values and keys read in its one-line message."""

from __future__ import annotations

import difflib
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

NO_VALUE: Any = object()
"""A :class:`WorldError` about a key without a value to show."""


def format_value(value: Any, limit: int = 60, depth: int = 0) -> str:
    """A value as it would be written in TOML, shortened to ``limit`` characters (long
    strings and collections are cut before they are formatted in full)."""
    if isinstance(value, np.generic | np.ndarray):  # a numpy value from cross-key code
        value = value.tolist()
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = json.dumps(value[: limit + 1], ensure_ascii=False)
    elif isinstance(value, list | tuple | dict) and depth > 8:
        text = "[...]" if isinstance(value, list | tuple) else "{...}"
    elif isinstance(value, list | tuple):
        text = "[" + ", ".join(format_value(v, limit, depth + 1) for v in value[:limit]) + "]"
    elif isinstance(value, dict):
        items = list(value.items())[:limit]
        text = "{" + ", ".join(f"{k} = {format_value(v, limit, depth + 1)}"
                               for k, v in items) + "}"
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """``" (did you mean 'x'?)"`` for the choices closest to ``word`` by
    :func:`difflib.get_close_matches` (cutoff 0.6, at most three), else ``""``."""
    close = difflib.get_close_matches(word, list(choices), n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""


def format_key(key: str) -> str:
    """``"vehicle.speed_mps"`` -> ``"[vehicle] speed_mps"``; top-level keys stay bare."""
    head, _, last = key.rpartition(".")
    return f"[{head}] {last}" if head else last


class WorldError(ValueError):
    """A world file that cannot be used, with the file, the dotted key and the reason.

    ``str(err)`` reads ``"worlds/bailey.toml: [vehicle] speed_mps = -3.0: must be in (0, 50]"``.
    ``key`` is ``None`` for faults of the file as a whole (missing file, TOML syntax);
    ``line`` is the line number of a TOML syntax error, else ``None``.
    """

    def __init__(
        self,
        file: str,
        key: str | None,
        message: str,
        value: Any = NO_VALUE,
        line: int | None = None,
    ) -> None:
        self.file = str(file)
        self.key = key
        self.message = message
        self.value = value
        self.line = line
        super().__init__(str(self))

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickle by the constructor's arguments (errors cross the worker pool intact)."""
        has_value = self.value is not NO_VALUE
        return (_world_error, (self.file, self.key, self.message, has_value,
                               self.value if has_value else None, self.line))

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        if self.key is None:
            return f"{where}: {self.message}"
        shown = "" if self.value is NO_VALUE else f" = {format_value(self.value)}"
        return f"{where}: {format_key(self.key)}{shown}: {self.message}"


def _world_error(file: str, key: str | None, message: str, has_value: bool, value: Any,
                 line: int | None) -> WorldError:
    """Rebuild a pickled :class:`WorldError` (``NO_VALUE`` is not picklable by identity)."""
    return WorldError(file, key, message, value if has_value else NO_VALUE, line)
