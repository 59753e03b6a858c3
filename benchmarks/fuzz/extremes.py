"""Schema-driven world families: underflowing σ and each kind's sizes at their maxima.

``underflow-sigma`` sets σ / noise-density / variance / γ keys - found by name in the
kind's schema (:func:`~benchmarks.fuzz.schemas.noise_keys`) and in the bundled world -
to allowed values whose square (or whose product with a unit factor) underflows:
1e-300, 1e-160, subnormals.  A valid world must then either be refused naming the key or
run with the failure counted; a ``NotPositiveDefiniteError`` traceback is the bug class.

``kind-size`` pushes each kind's rate, duration and sample-period keys
(:func:`~benchmarks.fuzz.schemas.size_keys`) to the most expensive value the schema
allows, alone or combined (alignment's IMU at 10 kHz for an hour, ship's gyro at 10 kHz
for a day, spinning at 1 ms for 1000 s), or to a tenth or hundredth of it: the world
must be refused by a work limit before anything is allocated, else it is a ``memory``
or ``hang`` case.
"""

from __future__ import annotations

import copy
import random
from collections.abc import Callable
from typing import Any

from . import tomlio
from .core import Base, Case, KeyPath, dotted, get, registrar, render
from .schemas import (
    NOISE,
    SIZE_DOWN,
    KeySpec,
    doc_numeric_paths,
    noise_keys,
    numeric_keys,
    size_keys,
)

FAMILIES: dict[str, Callable[[random.Random, Base], Case]] = {}
"""The families of this module, by name, in definition order."""
mutator = registrar(FAMILIES)

TINY = (1e-300, 1e-160, 1e-200, 5e-324, 1e-310, 2.2250738585072014e-308)
"""Positive values whose square is 0 or subnormal (1e-160² = 1e-320), or subnormal."""


def _put_path(doc: dict[str, Any], path: KeyPath, v: Any) -> None:
    """Set ``path`` in ``doc``, making the tables on the way (an optional section)."""
    t = doc
    for p in path[:-1]:
        nxt = t.get(p) if isinstance(t, dict) else None
        if not isinstance(nxt, dict):
            nxt = {}
            t[p] = nxt
        t = nxt
    t[path[-1]] = v


def _tiny_value(old: Any, tiny: float, spec: KeySpec | None, rng: random.Random) -> Any:
    """``tiny`` in the shape of ``old`` (or of the schema's key): a number, or a vector /
    list with every entry (or one) tiny."""
    n = len(old) if isinstance(old, list) and old else (spec.length if spec else None)
    shaped = isinstance(old, list) or (spec is not None and spec.shape in ("vector", "list"))
    if not shaped:
        return tiny
    n = n or 1
    if isinstance(old, list) and rng.random() < 0.4:
        out = list(old)
        out[rng.randrange(n)] = tiny
        return out
    return [tiny] * n


def _noise_targets(base: Base) -> list[tuple[KeyPath, KeySpec | None]]:
    """Every σ/noise key of the base's kind that allows 1e-300: from its schema, then the
    bundled world's noise-named numbers the schema walk did not find (a kind's own field
    class).  A declared key whose range excludes 1e-300 is left out: its refusal would
    hide every other key's outcome."""
    found: list[tuple[KeyPath, KeySpec | None]] = [(k.path, k) for k in noise_keys(base.kind)]
    declared = {k.path for k in numeric_keys(base.kind)}
    found += [(p, None) for p in doc_numeric_paths(base.doc, NOISE) if p not in declared]
    return found


@mutator("underflow-sigma")
def fam_underflow(rng: random.Random, base: Base) -> Case:
    """One σ/noise key, one section's, or every one set to 1e-300, 1e-160 or a subnormal
    (an allowed value whose square underflows)."""
    doc = copy.deepcopy(base.doc)
    targets = _noise_targets(base)
    if not targets:  # a kind with no noise key: a σ it does not know (refused)
        targets = [(("sensor", "sigma_range_m"), None)]
    tiny = rng.choice(TINY)
    scope = rng.random()  # every key finds a class; one key names the key behind it
    if scope < 0.3:
        chosen = [rng.choice(targets)]
        where = dotted(chosen[0][0])
    elif scope < 0.6:
        section = rng.choice(sorted({p[0] for p, _ in targets}))
        chosen = [t for t in targets if t[0][0] == section]
        where = f"every noise key of [{section}]" if len(chosen) > 1 else dotted(chosen[0][0])
    else:
        chosen = targets
        where = f"every noise key ({len(chosen)})"
    shown = ""
    for path, spec in chosen:
        old = _old(doc, path)
        new = _tiny_value(old, tiny, spec, rng)
        _put_path(doc, path, new)
        shown = tomlio.value(new)
    shown = shown if len(chosen) == 1 else repr(tiny)
    return render(base, "underflow-sigma", f"{where} = {shown}", doc)


@mutator("kind-size")
def fam_kind_size(rng: random.Random, base: Base) -> Case:
    """The kind's rate/duration/sample-period keys at their schema maxima (minima for a
    period), all together, one rate with the duration, or one alone; at full scale or a
    tenth or hundredth of it (slow but perhaps bounded)."""
    doc = copy.deepcopy(base.doc)
    keys = size_keys(base.kind)
    if not keys:
        doc["duration_s"] = 86_400.0
        return render(base, "kind-size", "duration_s = 86400 (no size keys known)", doc)
    rates = [k for k in keys if k[0].name.endswith("rate_hz")]
    lengths = [k for k in keys if not k[0].name.endswith("rate_hz")]
    how = rng.random()
    if how < 0.4:
        chosen, what = keys, "every size key"
    elif how < 0.8 and rates and lengths:
        chosen, what = [rng.choice(rates), *lengths], "a rate with the lengths"
    else:
        chosen, what = [rng.choice(keys)], "one key"
    scale = rng.choice([1.0, 1.0, 1.0, 0.1, 0.01])
    parts = []
    for spec, extreme in chosen:
        old = _old(doc, spec.path)
        v = _scaled(spec, extreme, scale, old)
        _put_path(doc, spec.path, v)
        parts.append(f"{dotted(spec.path)} = {tomlio.value(v)}")
    if doc == base.doc:  # the base already sits there: the first key it does not
        spec, extreme = next((k for k in keys if _old(doc, k[0].path) != k[1]), keys[0])
        _put_path(doc, spec.path, extreme)
        parts.append(f"{dotted(spec.path)} = {tomlio.value(extreme)}")
    label = f"{what} at {'the limit' if scale == 1 else f'{scale:g} x the limit'}"
    return render(base, "kind-size", f"{label}: {', '.join(parts)}", doc)


def _old(doc: dict[str, Any], path: KeyPath) -> Any:
    """The value at ``path``, ``None`` where it is absent."""
    try:
        return get(doc, path)
    except (KeyError, TypeError, IndexError):
        return None


def _scaled(spec: KeySpec, extreme: float, scale: float, old: Any) -> float | int:
    """``extreme`` moved towards the cheap end by ``scale`` (divided for a period), but
    never cheaper than the base's own value ``old``; inside the schema's interval and an
    integer for an integer key."""
    down = bool(SIZE_DOWN.search(spec.name))
    v = extreme / scale if down else extreme * scale
    if spec.shape == "integer":
        v = max(1, round(v))
    if isinstance(old, int | float) and not isinstance(old, bool):
        v = min(v, old) if down else max(v, old)
    if not spec.allows(v):
        v = extreme
    return v if spec.shape == "integer" else float(v)
