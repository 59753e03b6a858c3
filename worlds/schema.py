"""Validation machinery for world files: typed keys with allowed ranges.

A schema is a ``dict`` from key name to a :class:`Field` (or a nested :class:`Section`):
the declarative table of a world kind's sections, keys, types, ranges and units.
:func:`read_table` checks a parsed TOML table against it - unknown keys, missing
required keys, wrong types, values outside their allowed range - and returns the
converted values (degrees become radians here, for keys whose name says ``_deg``).
Every failure is a :class:`WorldError` that names the file, the dotted key and the rule.

The same table says where each value goes: :func:`build` fills a dataclass from the
converted values, each key under its field's name (``Field.to("max_steer_rad")``; a
:class:`Section` names its dataclass with ``into``).  Checks across keys are
:class:`Rule` rows (:func:`check_rules`) or a kind's own small functions.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Self

import numpy as np

from worlds.errors import (  # noqa: F401  (the schema's names for them)
    NO_VALUE,
    WorldError,
    did_you_mean,
    format_key,
    format_value,
)
from worlds.limits import MIN_VARIANCE
from worlds.rules import (  # noqa: F401
    Rule,
    check_rules,
    is_whole,
    value_at,
    whole_periods,
    whole_times,
)

REQUIRED: Any = object()
AS_KEY: Any = object()
"""The dataclass field a key fills by default: the one named like the key."""


@dataclass(frozen=True)
class Interval:
    """An allowed numeric range, open or closed at either end."""

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False

    def __contains__(self, v: float) -> bool:
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        return bool(above and below)

    def __str__(self) -> str:
        def num(x: float) -> str:
            return f"{x:g}" if abs(x) < 1e6 else f"{x:.6g}"

        return (
            f"{'(' if self.lo_open else '['}{num(self.lo)}, "
            f"{num(self.hi)}{')' if self.hi_open else ']'}"
        )


def positive(hi: float) -> Interval:
    """``(0, hi]``."""
    return Interval(0.0, hi, lo_open=True)


@dataclass(frozen=True)
class Where:
    """The place a value sits: the file and the dotted key; raises errors there."""

    file: str
    key: str

    def child(self, name: str) -> Where:
        return Where(self.file, f"{self.key}.{name}" if self.key else name)

    def item(self, index: int) -> Where:
        return Where(self.file, f"{self.key}[{index}]")

    def error(self, message: str, value: Any = NO_VALUE) -> WorldError:
        return WorldError(self.file, self.key, message, value)


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _numbers(value: list[Any], interval: Interval, scale: float, where: Where
             ) -> tuple[float, ...]:
    """The items of a list key, each a number in ``interval``, times ``scale``."""
    for i, v in enumerate(value):
        if not _is_number(v):
            raise where.item(i).error("must be a number", v)
        if v not in interval:
            raise where.item(i).error(f"must be in {interval}", v)
    return tuple(float(v) * scale for v in value)


class Field(ABC):
    """One key: a parser from its TOML value, a default (or :data:`REQUIRED`), and the
    dataclass field it fills (``attr``: :data:`AS_KEY`, another name, or ``None`` for a
    key that a kind's cross-key code turns into a field)."""

    default: Any = REQUIRED
    attr: str | None = AS_KEY

    @abstractmethod
    def parse(self, value: Any, where: Where) -> Any:
        """The checked, converted value; raises :class:`WorldError` naming the key."""

    def to(self, attr: str | None) -> Self:
        """This field, filling the dataclass field ``attr`` (``None``: none) in :func:`build`."""
        out = copy.copy(self)
        out.attr = attr
        return out


class Number(Field):
    """A real number in ``interval``; ``_deg`` keys are multiplied by ``scale``."""

    def __init__(self, interval: Interval, default: Any = REQUIRED, scale: float = 1.0) -> None:
        self.interval, self.default, self.scale = interval, default, scale

    def parse(self, value: Any, where: Where) -> float:
        if not _is_number(value):
            raise where.error("must be a number", value)
        if value not in self.interval:
            raise where.error(f"must be in {self.interval}", value)
        return float(value) * self.scale


def check_variance(value: float, power: int, interval: Interval, scale: float,
                   where: Where, given: Any) -> None:
    """Refuse a non-zero σ (``power`` 2) or variance (``power`` 1), already in SI units,
    whose variance ``value**power`` is below :data:`~worlds.limits.MIN_VARIANCE`: its
    square underflows (to 0 or a subnormal number) in the filters' covariances, which then
    are not positive definite.  0 stays allowed where ``interval`` allows it; a value
    given as non-zero that the unit conversion rounds to 0 is refused too."""
    if (value == 0.0 and given == 0) or abs(value) ** power >= MIN_VARIANCE:
        return
    lo = MIN_VARIANCE ** (1.0 / power) / scale  # the smallest value in file units
    zero = "0 or " if 0.0 in interval else ""
    what = "σ²" if power == 2 else "variance"
    raise where.error(f"must be {zero}at least {lo:.3g} (below, its {what} in SI units "
                      f"is under {MIN_VARIANCE:g} and underflows in the filters)", given)


class Sigma(Number):
    """A standard deviation, noise density or H∞ bound (``power`` 2: its square enters a
    covariance) or a variance or a factor on one (``power`` 1), in ``interval`` and times
    ``scale`` like a :class:`Number`; when not 0, its variance in SI units must be at least
    :data:`~worlds.limits.MIN_VARIANCE` (:func:`check_variance`)."""

    def __init__(self, interval: Interval, default: Any = REQUIRED, scale: float = 1.0,
                 power: int = 2) -> None:
        super().__init__(interval, default, scale)
        self.power = power

    def parse(self, value: Any, where: Where) -> float:
        out = super().parse(value, where)
        check_variance(out, self.power, self.interval, self.scale, where, value)
        return out


class Integer(Field):
    """A whole number in ``interval``."""

    def __init__(self, interval: Interval, default: Any = REQUIRED) -> None:
        self.interval, self.default = interval, default

    def parse(self, value: Any, where: Where) -> int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise where.error("must be an integer", value)
        if value not in self.interval:
            raise where.error(f"must be an integer in {self.interval}", value)
        return int(value)


class Boolean(Field):
    def __init__(self, default: Any = REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: Where) -> bool:
        if not isinstance(value, bool):
            raise where.error("must be true or false", value)
        return value


class String(Field):
    """A string, optionally one of ``choices``; ``one_line`` forbids newlines and empties."""

    def __init__(
        self,
        choices: tuple[str, ...] | None = None,
        default: Any = REQUIRED,
        one_line: bool = False,
        max_len: int = 1000,
    ) -> None:
        self.choices, self.default, self.one_line, self.max_len = (
            choices,
            default,
            one_line,
            max_len,
        )

    def parse(self, value: Any, where: Where) -> str:
        if not isinstance(value, str):
            raise where.error("must be a string", value)
        if self.choices is not None and value not in self.choices:
            raise where.error(f"must be one of {', '.join(map(repr, self.choices))}", value)
        if self.one_line and (not value.strip() or "\n" in value):
            raise where.error("must be one non-empty line", value)
        if len(value) > self.max_len:
            raise where.error(f"must be at most {self.max_len} characters", value)
        return value


class StringList(Field):
    """A non-empty list of distinct strings, each one of ``choices``."""

    def __init__(self, choices: tuple[str, ...], default: Any = REQUIRED) -> None:
        self.choices, self.default = choices, default

    def parse(self, value: Any, where: Where) -> tuple[str, ...]:
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise where.error("must be a list of strings", value)
        if not value:
            raise where.error("must name at least one", value)
        for i, v in enumerate(value):
            if v not in self.choices:
                raise where.item(i).error(f"unknown; allowed: {', '.join(self.choices)}", v)
        if len(set(value)) != len(value):
            raise where.error("must not repeat a name", value)
        return tuple(value)


class Vector(Field):
    """A fixed-length list of numbers, each in ``interval`` and multiplied by ``scale``."""

    def __init__(self, length: int, interval: Interval, default: Any = REQUIRED,
                 scale: float = 1.0) -> None:
        self.length, self.interval, self.default, self.scale = length, interval, default, scale

    def parse(self, value: Any, where: Where) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != self.length:
            raise where.error(f"must be a list of {self.length} numbers", value)
        return _numbers(value, self.interval, self.scale, where)


class SigmaVector(Vector):
    """A :class:`Vector` of standard deviations, each checked like a :class:`Sigma`."""

    def parse(self, value: Any, where: Where) -> tuple[float, ...]:
        out = super().parse(value, where)
        for i, v in enumerate(out):
            check_variance(v, 2, self.interval, self.scale, where.item(i), value[i])
        return out


class NumberList(Field):
    """A non-empty list of numbers, each in ``interval``, multiplied by ``scale``."""

    def __init__(self, interval: Interval, scale: float = 1.0, max_len: int = 1000,
                 default: Any = REQUIRED) -> None:
        self.interval, self.scale, self.max_len, self.default = interval, scale, max_len, default

    def parse(self, value: Any, where: Where) -> tuple[float, ...]:
        if not isinstance(value, list) or not 0 < len(value) <= self.max_len:
            raise where.error(f"must be a list of 1 to {self.max_len} numbers", value)
        return _numbers(value, self.interval, self.scale, where)


class Points(Field):
    """A list of ``[x, y]`` pairs of finite numbers -> float array ``(n, 2)``."""

    def __init__(self, default: Any = REQUIRED, max_count: int = 100_000) -> None:
        self.default, self.max_count = default, max_count

    def parse(self, value: Any, where: Where) -> np.ndarray:
        if not isinstance(value, list):
            raise where.error("must be a list of [x, y] pairs", value)
        if len(value) > self.max_count:
            raise where.error(f"must hold at most {self.max_count} points", len(value))
        for i, p in enumerate(value):
            if not (isinstance(p, list) and len(p) == 2 and all(map(_is_number, p))):
                raise where.item(i).error("must be an [x, y] pair of numbers", p)
            if not all(map(math.isfinite, p)):
                raise where.item(i).error("must be finite", p)
        return np.array(value, dtype=float).reshape(-1, 2)


class FreeForm(Field):
    """Any nesting of tables, lists, strings, numbers and booleans (JSON-compatible)."""

    def __init__(self, default: Any = REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: Where) -> Any:
        return self._free(value, where)

    def _free(self, value: Any, where: Where) -> Any:
        if isinstance(value, dict):
            return {k: self._free(v, where.child(k)) for k, v in value.items()}
        if isinstance(value, list):
            return [self._free(v, where.item(i)) for i, v in enumerate(value)]
        if isinstance(value, str | bool | int):
            return value
        if isinstance(value, float):
            if not math.isfinite(value):
                raise where.error("must be finite", value)
            return value
        raise where.error("must be a string, number, boolean, list or table", str(value))


class Table(Field):
    """A table of any keys (checked further by whoever reads it)."""

    def __init__(self, default: Any = REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: Where) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise where.error("must be a table", value)
        return value


TEXT = String(max_len=10_000)
"""A free-form table's text (a source, a statement)."""
REAL = Number(Interval(-math.inf, math.inf))
"""A free-form table's finite number."""
PAIR = Vector(2, Interval(-math.inf, math.inf))
"""A free-form table's ``[lo, hi]`` pair of finite numbers."""


class Paper(FreeForm):
    """The free-form ``[paper]`` table (:class:`FreeForm`, and a table), with the types of
    the keys a kind's report reads: ``typed`` maps a dotted path inside it (``*`` stands
    for any one key, e.g. ``"filters.*.pos_err_range_m.*"``) to the :class:`Field` its
    value must pass; a table on the way to a typed key must be a table.  Other keys pass
    through unchecked.  The value is returned as written (lists stay lists)."""

    def __init__(self, typed: Mapping[str, Field] | None = None, default: Any = dict) -> None:
        super().__init__(default)
        self.typed = tuple((tuple(k.split(".")), f) for k, f in (typed or {}).items())

    def parse(self, value: Any, where: Where) -> Any:
        out = super().parse(value, where)
        if not isinstance(out, dict):
            raise where.error("must be a table", value)
        self._check(out, (), where)
        return out

    def _check(self, node: dict[str, Any], path: tuple[str, ...], where: Where) -> None:
        for key, v in node.items():
            at, here = where.child(key), (*path, key)
            for pattern, spec in self.typed:
                if len(pattern) < len(here) or not all(
                        p in ("*", k) for p, k in zip(pattern, here)):
                    continue
                if len(pattern) == len(here):
                    spec.parse(v, at)
                elif not isinstance(v, dict):
                    raise at.error(f"must be a table (the report reads "
                                   f"{'.'.join(pattern[len(here):])} in it)", v)
            if isinstance(v, dict):
                self._check(v, here, at)


@dataclass(frozen=True)
class Section:
    """A sub-table with its own schema; an optional section may be left out entirely.

    ``into``: the dataclass :func:`build` makes of it; ``attr`` as for :class:`Field`.
    """

    schema: Mapping[str, Field | Section]
    required: bool = True
    into: type | None = None
    attr: str | None = AS_KEY

    def to(self, attr: str | None) -> Section:
        """This section, filling the dataclass field ``attr`` in :func:`build`."""
        return dataclasses.replace(self, attr=attr)


def header(kind: str) -> dict[str, Field]:
    """The keys every world file starts with: ``kind``, a one-line ``description``, the
    Monte Carlo ``runs`` and the campaign ``seed``."""
    return {
        "kind": String(choices=(kind,)),
        "description": String(one_line=True, max_len=200),
        "runs": Integer(Interval(1, 100_000)),
        "seed": Integer(Interval(0, 2**63 - 1), default=0),
    }


@dataclasses.dataclass(frozen=True)
class SiteSpec:
    """A place on the Earth (radians, metres); its latitude sets the Earth rate."""

    latitude_rad: float
    longitude_rad: float
    height_m: float


def site(latitude_max_deg: float, height_m: Interval, height_default: Any = REQUIRED
         ) -> Section:
    """The ``[site]`` table of a navigation world: ``latitude_deg`` within
    ±``latitude_max_deg``, ``longitude_deg``, ``height_m`` in ``height_m``."""
    deg = math.pi / 180.0
    return Section({
        "latitude_deg": Number(Interval(-latitude_max_deg, latitude_max_deg),
                               scale=deg).to("latitude_rad"),
        "longitude_deg": Number(Interval(-180.0, 180.0), scale=deg).to("longitude_rad"),
        "height_m": Number(height_m, default=height_default),
    }, into=SiteSpec)


def read_table(data: Any, schema: Mapping[str, Field | Section], where: Where) -> dict[str, Any]:
    """Check ``data`` against ``schema``; return ``{key: converted value}`` for every key.

    Unknown keys are reported before missing or malformed ones, since a misspelt key
    is the usual cause of a "missing" one.
    """
    if not isinstance(data, dict):
        raise where.error("must be a table", data)
    for key in data:
        if key not in schema:
            allowed = ", ".join(schema) or "none"
            hint = did_you_mean(key, list(schema)) if isinstance(key, str) else ""
            raise where.child(key).error(f"unknown key{hint} (allowed: {allowed})")
    out: dict[str, Any] = {}
    for key, spec in schema.items():
        at = where.child(key)
        if isinstance(spec, Section):
            if key not in data and spec.required:
                raise at.error("missing section (required)")
            out[key] = read_table(data.get(key, {}), spec.schema, at)
        elif key in data:
            out[key] = spec.parse(data[key], at)
        elif spec.default is REQUIRED:
            raise at.error("missing (required)")
        else:
            default = spec.default
            out[key] = default() if isinstance(default, Callable) else _default(spec, default, at)
    return out


def _default(spec: Field, default: Any, where: Where) -> Any:
    """Defaults are written in file units; pass them through the parser (None stays None)."""
    if default is None:
        return None
    return spec.parse(default, where)


def build(section: Section, values: Mapping[str, Any], **derived: Any) -> Any:
    """``section.into(...)`` from the values :func:`read_table` returned for it.

    Each key's value fills the field its spec names (:attr:`Field.attr`); a sub-section
    is built the same way; ``derived`` gives the fields that the kind computes (a key
    whose field is among them is passed over).
    """
    if section.into is None:
        raise TypeError("a section built into a dataclass needs into=")
    fields: dict[str, Any] = {}
    for key, spec in section.schema.items():
        name = key if spec.attr is AS_KEY else spec.attr
        if name is None or name in derived:
            continue
        value = values[key]
        fields[name] = build(spec, value) if isinstance(spec, Section) else value
    return section.into(**fields, **derived)
