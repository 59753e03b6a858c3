"""Deterministic, seeded mutators for TOML worlds and GTSAM-format planar logs.

A :class:`Case` is one generated input: the bytes of the file to hand to ``slam run``
(or a path to pass instead), any side files it names, its mutator family and a short
description. ``world_cases(n, seed, bases)`` and ``log_cases(n, seed, lines)`` return
the same cases for the same arguments on any machine; case ``i`` draws from its own
``random.Random(f"{seed}:{kind}:{i}")`` and families are dealt round-robin, so every
family is exercised about equally.

World documents are made cheap before they are mutated (one filter, one planar loop, a
short attitude run: :func:`~benchmarks.fuzz.core.cheapen`), so a case runs in seconds;
the mutation itself is the thing under test and may undo that (e.g. ``loops = 100``).
"""

from __future__ import annotations

import copy
import random
from collections.abc import Callable
from typing import Any

from . import extremes, paths, shapes, textual, tomlio
from .core import (
    Base,
    Case,
    KeyPath,
    cheapen,
    dotted,
    get,
    is_num,
    load_bases,
    pick,
    put,
    registrar,
    render,
    seeded_families,
)
from .logmutate import LOG_FAMILIES, load_log_lines, log_cases

__all__ = ["Base", "Case", "WORLD_FAMILIES", "LOG_FAMILIES", "load_bases", "load_log_lines",
           "log_cases", "world_cases", "cheapen", "render"]

WORLD_FAMILIES: dict[str, Callable[[random.Random, Base], Case]] = {}
"""World mutator families, by name: this module's in definition order (each added by
``@mutator``), then those of :mod:`~benchmarks.fuzz.shapes`, :mod:`~benchmarks.fuzz.extremes`,
:mod:`~benchmarks.fuzz.paths` and :mod:`~benchmarks.fuzz.textual` (added after the last)."""
mutator = registrar(WORLD_FAMILIES)


# --------------------------------------------------------------------------- value families

def _set_value(rng: random.Random, base: Base, family: str,
               want: Callable[[Any], bool], make: Callable[[Any], Any]) -> Case:
    """Set one value chosen by ``want`` to ``make(old)``; a few tries to find a change."""
    doc = copy.deepcopy(base.doc)
    path: KeyPath = ("runs",)
    old: Any = 1
    new: Any = make(old)
    for _ in range(20):
        found = pick(rng, doc, want)
        if found is None:
            break
        path, old = found, get(doc, found)
        new = make(old)
        if tomlio.value(new) != tomlio.value(old):
            break
    put(doc, path, new)
    return render(base, family, f"{dotted(path)} = {tomlio.value(new)}", doc)


@mutator("delete-key")
def fam_delete(rng: random.Random, base: Base) -> Case:
    """Delete one key or a whole section."""
    doc = copy.deepcopy(base.doc)
    path = pick(rng, doc, lambda v: True, items=False) or ("kind",)
    del get(doc, path[:-1])[path[-1]]
    return render(base, "delete-key", f"del {dotted(path)}", doc)


_RENAMES: tuple[Callable[[str], str], ...] = (
    lambda k: k + "s", lambda k: k.upper(), lambda k: k[:-1] or "x",
    lambda k: k.replace("_", "-"), lambda k: " " + k, lambda k: k + "\u200b",
    lambda k: k.replace("a", "\u0430"), lambda k: "",
)


@mutator("rename-key")
def fam_rename(rng: random.Random, base: Base) -> Case:
    """Misspell one key or section name (plural, case, homoglyph, empty ...)."""
    doc = copy.deepcopy(base.doc)
    path = pick(rng, doc, lambda v: True, items=False) or ("kind",)
    parent, old = get(doc, path[:-1]), str(path[-1])
    new = rng.choice(_RENAMES)(old)
    if new == old or new in parent:
        new = old + "_x"
    parent[new] = parent.pop(old)
    return render(base, "rename-key", f"rename {dotted(path)} -> {new!r}", doc)


def _wrong(v: Any, rng: random.Random) -> Any:
    import datetime as dt

    options: list[Any] = [
        "3", "", True, [], [1.0, 2.0], {"x": 1}, ["planar-slam"], "nan", "١٢٣",
        dt.datetime(1979, 5, 27, 7, 32, tzinfo=dt.UTC), dt.date(2020, 1, 1), dt.time(7, 32),
    ]
    if isinstance(v, float):
        options += [int(v) if abs(v) < 1e18 and v == v else 3]
    elif isinstance(v, int) and not isinstance(v, bool):
        options += [float(v) + 0.5]
    options = [o for o in options if type(o) is not type(v)]
    return rng.choice(options)


@mutator("wrong-type")
def fam_wrong_type(rng: random.Random, base: Base) -> Case:
    """Give one value another TOML type (string, bool, array, table, date ...)."""
    return _set_value(rng, base, "wrong-type", lambda v: not isinstance(v, dict),
                      lambda v: _wrong(v, rng))


@mutator("nonfinite")
def fam_nonfinite(rng: random.Random, base: Base) -> Case:
    """Set one number to nan, inf or -inf."""
    return _set_value(rng, base, "nonfinite", is_num,
                      lambda v: rng.choice([float("nan"), float("inf"), float("-inf")]))


@mutator("zero")
def fam_zero(rng: random.Random, base: Base) -> Case:
    """Set one number to 0 (or -0.0)."""
    return _set_value(rng, base, "zero", is_num,
                      lambda v: 0 if isinstance(v, int) else rng.choice([0.0, -0.0]))


@mutator("negative")
def fam_negative(rng: random.Random, base: Base) -> Case:
    """Make one number negative."""
    def neg(v: Any) -> Any:
        """-|v|, or a negative number for 0."""
        if v == 0:
            return -1 if isinstance(v, int) else rng.choice([-1.0, -1e-12])
        return -abs(v)

    return _set_value(rng, base, "negative", is_num, neg)


_FLOAT_EXTREMES = (1e308, -1e308, 1e-308, -1e-308, 5e-324, 1e-300, 1.7976931348623157e308,
                   1e-12, 1e12)
_INT_EXTREMES = (2**63 - 1, -(2**63), 2**64, 10**30, 10**9, 2**31)


@mutator("extreme")
def fam_extreme(rng: random.Random, base: Base) -> Case:
    """Set one number to 1e+-308, 5e-324, 2**63 and the like."""
    def ext(v: Any) -> Any:
        """An extreme int (mostly, for ints) or float."""
        ints = isinstance(v, int) and rng.random() < 0.7
        return rng.choice(_INT_EXTREMES if ints else _FLOAT_EXTREMES)

    return _set_value(rng, base, "extreme", is_num, ext)


@mutator("in-range")
def fam_in_range(rng: random.Random, base: Base) -> Case:
    """Plausible values: a number scaled by 1e-6 ... 1e3 (kept an integer if it was)."""
    def scale(v: Any) -> Any:
        """``v`` times a random factor, still an int if it was one."""
        f = rng.choice([1e-6, 1e-3, 0.1, 0.5, 2.0, 10.0, 1e3])
        if isinstance(v, int):
            return max(1, int(v * f)) if v > 0 else int(v * f)
        return v * f

    return _set_value(rng, base, "in-range", is_num, scale)


@mutator("arrays")
def fam_arrays(rng: random.Random, base: Base) -> Case:
    """Empty, shorten, lengthen, nest or mix one array."""
    doc = copy.deepcopy(base.doc)
    path = pick(rng, doc, lambda v: isinstance(v, list), items=False)
    if path is None:
        path = ("filters", "names") if "filters" in doc else ("extra",)
        put(doc, path, [])
        return render(base, "arrays", f"{dotted(path)} = []", doc)
    v = get(doc, path)
    first = v[0] if v else 0.0
    choices: list[tuple[str, Any]] = [
        ("empty", []), ("drop last", v[:-1]), ("append", [*v, copy.deepcopy(first)]),
        ("nested", [v]), ("string item", ["x", *v[1:]]), ("one item", v[:1]),
        ("mixed types", [*v[:-1], "1.0"] if v else ["1.0"]),
    ]
    if v and isinstance(first, list):
        choices += [("3-vectors", [[*p, 0.0] if isinstance(p, list) else p for p in v]),
                    ("flattened", [x for p in v if isinstance(p, list) for x in p]),
                    ("100001 points", [[float(i % 97), float(i % 89)] for i in range(100_001)])]
    what, new = rng.choice(choices)
    if new == v:
        what, new = "nested", [v]
    put(doc, path, new)
    return render(base, "arrays", f"{dotted(path)}: {what}", doc)


@mutator("kind")
def fam_kind(rng: random.Random, base: Base) -> Case:
    """An unknown, mistyped, missing or foreign ``kind``."""
    doc = copy.deepcopy(base.doc)
    others = ["planar-slam", "drone-slam", "attitude"]
    new = rng.choice([
        "planar-slam2", "", "PLANAR-SLAM", [base.kind], {"a": 1}, 1, True, " " + base.kind,
        rng.choice([k for k in others if k != base.kind]), None,
    ])
    if new is None:
        doc.pop("kind", None)
        return render(base, "kind", "del kind", doc)
    doc["kind"] = new
    return render(base, "kind", f"kind = {tomlio.value(new)}", doc)


@mutator("filters")
def fam_filters(rng: random.Random, base: Base) -> Case:
    """Unknown, repeated or empty filter names; unknown modes and associations."""
    doc = copy.deepcopy(base.doc)
    filt = doc.setdefault("filters", {})
    key, new = rng.choice([(k, v) for k, v in [
        ("names", ["nope"]), ("names", []), ("names", ["srckf", "srckf"]), ("names", ["SRCKF"]),
        ("names", "srckf"), ("names", ["ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf"]),
        ("names", ["svdckf"]), ("names", ["hinf"]), ("names", [""]), ("mode", "hybrid"),
        ("mode", "LOCAL"), ("mode", "local"), ("association", "nn"), ("association", "bogus"),
        ("gate_accept", 1e-308), ("gate_new", 0.0), ("method", "magic"),
    ] if filt.get(k) != v])
    filt[key] = new
    return render(base, "filters", f"filters.{key} = {tomlio.value(new)}", doc)


for _module in (shapes, extremes, paths, textual):
    for _name, _fn in _module.FAMILIES.items():
        if _name in WORLD_FAMILIES:
            raise ValueError(f"mutator family {_name!r} defined twice")
        WORLD_FAMILIES[_name] = _fn


def world_cases(n: int, seed: int, bases: list[Base],
                families: list[str] | None = None) -> list[Case]:
    """``n`` world cases for ``seed``: case ``i`` uses family ``i mod F``; a family's
    ``k``-th case uses base ``k mod B`` of a seeded order of the bases (each family
    visits every base once before any twice)."""
    names = families or list(WORLD_FAMILIES)
    orders: dict[str, list[Base]] = {}
    for f in names:
        orders[f] = list(bases)
        random.Random(f"{seed}:bases:{f}").shuffle(orders[f])
    out = []
    for i, (rng, family) in enumerate(seeded_families(n, seed, "world", names)):
        base = orders[family][(i // len(names)) % len(bases)]
        out.append(WORLD_FAMILIES[family](rng, base))
    return out


