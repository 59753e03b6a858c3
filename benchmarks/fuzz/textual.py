"""World families on what the schema leaves loose: the free-form ``[paper]`` table and
TOML's dotted keys.

``paper-types``: a ``[paper]`` value replaced by a number, boolean, list, nested table or
date where the report expects text, by text where it expects a number, a sub-table by a
scalar, or ``paper`` itself made a scalar; the case is run with figures (the figures read
``[paper]`` too).  The report must render whatever the type, or the world be refused naming
the key - an ``AttributeError`` after the campaign is the bug class.

``long-dotted-key``: one key of 1 000 - 30 000 dotted parts (a world of up to ~210 KB,
~270 KB with quoted parts) as an assignment, a table header, an array-of-tables header, an
inline table or quoted parts, at the top level or in ``[paper]``; or 200 keys of 500 parts.
``tomllib``'s cost grows with the square of a key's parts (30 000 parts: ~4 GB), so the
input must be bounded before it is parsed: a ``memory`` case, or a ``costly-rejection``
(refused, but only after seconds and GB), is the bug class.
"""

from __future__ import annotations

import copy
import datetime as dt
import random
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from . import tomlio
from .core import Base, Case, KeyPath, dotted, get, put, registrar, render, walk

FAMILIES: dict[str, Callable[[random.Random, Base], Case]] = {}
"""The families of this module, by name, in definition order."""
mutator = registrar(FAMILIES)


# --------------------------------------------------------------------------- [paper]

_NOT_TEXT: tuple[Any, ...] = (3, 0.5, -1e308, 0, True, False, [], [1, 2], ["x", "y"],
                              {"a": {"b": 1}}, {}, dt.date(2020, 1, 1), [[1.0, 2.0]])
_NOT_NUMBER: tuple[Any, ...] = ("9.7", "", "n/a", True, [9.7], {"value": 9.7}, [[1.0]])


def _other_type(v: Any, rng: random.Random) -> Any:
    """A value of another TOML type than ``v``: text for a number, and the reverse."""
    pool = _NOT_NUMBER if isinstance(v, int | float) and not isinstance(v, bool) else _NOT_TEXT
    options = [o for o in pool if type(o) is not type(v) or o != v]
    return copy.deepcopy(rng.choice(options))


@mutator("paper-types")
def fam_paper_types(rng: random.Random, base: Base) -> Case:
    """One ``[paper]`` value, sub-table or the table itself given another type."""
    doc = copy.deepcopy(base.doc)
    paper = doc.get("paper")
    if not isinstance(paper, dict) or not paper:
        paper = {"source": "fuzz", "filters": {"srckf": {"x": [-1.0, 1.0]}}}
        doc["paper"] = paper
    how = rng.random()
    if how < 0.1:
        new = rng.choice([3, "a paper", [1, 2], True])
        doc["paper"] = new
        name = f"paper = {tomlio.value(new)}"
    elif how < 0.25:
        tables = [p for p in walk(paper, items=False) if isinstance(get(paper, p), dict)]
        path: KeyPath = rng.choice(tables) if tables else (rng.choice(list(paper)),)
        new = rng.choice([3, "text", [1, 2], False])
        put(paper, path, new)
        name = f"paper.{dotted(path)} (a table) = {tomlio.value(new)}"
    else:
        leaves = [p for p in walk(paper) if not isinstance(get(paper, p), dict | list)]
        path = rng.choice(leaves) if leaves else ("source",)
        old = get(paper, path) if leaves else "text"
        new = _other_type(old, rng)
        put(paper, path, new)
        name = f"paper.{dotted(path)} = {tomlio.value(new)[:40]} (was {tomlio.value(old)[:30]})"
    return replace(render(base, "paper-types", name, doc), plots=True)


# --------------------------------------------------------------------------- dotted keys

STYLES = ("assignment", "table header", "array-of-tables header", "inline table",
          "quoted parts")


def dotted_key_text(parts: int, style: str, short: bool = False) -> str:
    """A TOML line (or header and line) with one key of ``parts`` dotted parts in
    ``style`` (:data:`STYLES`); parts are ``k00000``-style (7 bytes each) or, with
    ``short``, ``a``."""
    names = ["a"] * parts if short else [f"k{i:05d}" for i in range(parts)]
    if style == "quoted parts":
        return ".".join(f'"{n}"' for n in names) + " = 1\n"
    key = ".".join(names)
    if style == "table header":
        return f"[{key}]\nx = 1\n"
    if style == "array-of-tables header":
        return f"[[{key}]]\nx = 1\n"
    if style == "inline table":
        return f"fuzz_inline = {{{key} = 1}}\n"
    return f"{key} = 1\n"


def _insert(text: str, line: str, at_paper: bool) -> tuple[str, str]:
    """``line`` placed where it is valid TOML: a key line at the top (or right after the
    ``[paper]`` header), a header at the end."""
    if line.startswith("["):
        return text + "\n" + line, "at the end"
    lines = text.splitlines(keepends=True)
    if at_paper and "[paper]\n" in lines:
        lines.insert(lines.index("[paper]\n") + 1, line)
        return "".join(lines), "in [paper]"
    return line + text, "at the top level"


@mutator("long-dotted-key")
def fam_long_dotted_key(rng: random.Random, base: Base) -> Case:
    """A key of 1 000 - 30 000 dotted parts (see the module docstring), or many long ones."""
    text = tomlio.dumps(base.doc)
    if rng.random() < 0.15:
        many = "".join(f"m{j:03d}." + dotted_key_text(500, "assignment", short=True)
                       for j in range(200))
        return render(base, "long-dotted-key", "200 keys of 501 dotted parts", text=many + text)
    parts = rng.choice([1000, 5000, 20_000, 30_000, 30_000])
    style = rng.choice(STYLES)
    short = rng.random() < 0.3
    line = dotted_key_text(parts, style, short)
    new, where = _insert(text, line, rng.random() < 0.4)
    name = (f"{style}: one key of {parts} {'1-byte' if short else '6-byte'} parts {where} "
            f"({len(new) // 1000} KB)")
    return render(base, "long-dotted-key", name, text=new)
