"""Checks across the keys of a world: :class:`Rule` rows (``ok(value at key, value at
other)``) and the whole-number relations they use."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from worlds.schema import Where


def value_at(values: Mapping[str, Any], key: str) -> Any:
    """The value at the dotted ``key`` of nested checked tables."""
    for part in key.split("."):
        values = values[part]
    return values


def is_whole(x: float, tol: float = 1e-9) -> bool:
    """``x`` is a finite whole number to a relative ``tol``."""
    return math.isfinite(x) and abs(x - round(x)) <= tol * max(1.0, abs(x))


def whole_periods(duration: float, rate: float) -> bool:
    """``duration`` is a whole number (>= 1) of periods at ``rate``."""
    return is_whole(duration * rate) and duration * rate >= 1


def whole_times(value: float, other: float) -> bool:
    """``value`` goes into ``other`` a whole number (>= 1) of times."""
    ratio = other / value
    return is_whole(ratio) and round(ratio) >= 1


@dataclass(frozen=True)
class Rule:
    """A check across keys: ``ok(value at key, value at other)`` must hold, else the
    error at ``key`` reads ``message`` formatted with ``other`` (the other key's last
    name) and ``limit`` (its value), or ``message(limit)``."""

    key: str
    other: str
    ok: Callable[[Any, Any], bool]
    message: str | Callable[[Any], str]


def check_rules(rules: Sequence[Rule], values: Mapping[str, Any], where: Where) -> None:
    """Raise the :class:`WorldError` of the first rule that ``values`` break."""
    for rule in rules:
        value, limit = value_at(values, rule.key), value_at(values, rule.other)
        if not rule.ok(value, limit):
            other = rule.other.rpartition(".")[2]
            text = (rule.message(limit) if callable(rule.message)
                    else rule.message.format(other=other, limit=limit))
            raise where.child(rule.key).error(text, value)
