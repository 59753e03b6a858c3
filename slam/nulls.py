"""The summary's null convention, and the one check of it.

A ``summary.json`` never holds a null (``None``, or a non-finite float, which the JSON
writer turns into null) without its reason beside it.  A null at key ``k`` of a table
(or anywhere inside the list or table ``k`` holds) is explained when that table has

* ``k_reason`` (:func:`reason_key`): a non-empty string saying why; or
* a count key (:data:`COUNT_KEYS`: ``epochs``, ``runs_scored``, ``converged_runs``) equal
  to 0: the number of epochs (or runs) the table's statistics are computed over.  A
  count explains every null in its table and in the tables below it
  (``turn_split_rmse_deg.turns = {"roll": null, ..., "epochs": 0}``).  A count that is a
  list counts per item of the table's lists of the same length (``{"epochs": [0, 5],
  "east": [null, 0.4]}``: one count per window).

:func:`unexplained_nulls` lists every null that is not, by its path; the tests run it on a
small campaign of every kind and on degenerate worlds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

REASON_SUFFIX = "_reason"
COUNT_KEYS = ("epochs", "runs_scored", "converged_runs")
"""Keys that count what their table's statistics are computed over; 0 explains a null."""


def reason_key(key: str) -> str:
    """The key of the reason for a null at ``key``: ``key + "_reason"``."""
    return key + REASON_SUFFIX


def is_null(value: Any) -> bool:
    """``None`` or a non-finite float (null in ``summary.json``)."""
    if value is None:
        return True
    if isinstance(value, float | np.floating):
        return not math.isfinite(float(value))
    return False


def _is_count(v: Any) -> bool:
    return isinstance(v, int | np.integer) and not isinstance(v, bool)


def _counted_zero(table: Mapping[str, Any]) -> bool:
    return any(_is_count(table.get(k)) and table[k] == 0 for k in COUNT_KEYS)


def _item_counts(table: Mapping[str, Any]) -> list[Sequence[Any]]:
    return [table[k] for k in COUNT_KEYS if isinstance(table.get(k), list | tuple)
            and all(_is_count(c) for c in table[k])]


def _explained(table: Mapping[str, Any], key: str) -> bool:
    why = table.get(reason_key(key))
    return isinstance(why, str) and bool(why.strip())


def unexplained_nulls(summary: Any, path: str = "") -> list[str]:
    """Dotted paths (``filters.ins-ekf.turn_split_rmse_deg.turns.roll``, ``x.loops[1]``)
    of every null in ``summary`` without a reason beside it (module docstring)."""
    if isinstance(summary, Mapping):
        if _counted_zero(summary):
            return []
        counts = _item_counts(summary)
        out: list[str] = []
        for k, v in summary.items():
            here = f"{path}.{k}" if path else str(k)
            if _explained(summary, str(k)):
                continue
            if isinstance(v, list | tuple) and counts:
                out += [p for i, item in enumerate(v)
                        if not any(len(c) == len(v) and c[i] == 0 for c in counts)
                        for p in unexplained_nulls(item, f"{here}[{i}]")]
            else:
                out += unexplained_nulls(v, here)
        return out
    if isinstance(summary, list | tuple | np.ndarray):
        return [p for i, v in enumerate(summary) for p in unexplained_nulls(v, f"{path}[{i}]")]
    return [path] if is_null(summary) else []
