"""What the classifier reads in a finished run: ``summary.json`` and stderr.

* :func:`degenerate_reason` - a summary that is not a real score (no filters, a
  non-finite value, every error of a filter or the reference exactly 0, scores from 0
  runs ...);
* :func:`unexplained_nulls` - nulls in a summary with no reason beside them.  The
  project's convention: a null at key ``k`` has a sibling ``k_reason`` (a non-empty
  string), or sits next to (or below) a count of what it would be computed over that is
  0.  The rules are the pluggable tuple :data:`NULL_EXPLAINERS`; a null in the free-form
  ``paper`` table or in ``provenance`` (the record of the command, where a null is an
  option not given) is not checked;
* :func:`printed_warnings` - Python ``...Warning:`` lines on stderr (numpy's
  ``RuntimeWarning: invalid value encountered ...``).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

_METRIC = re.compile(r"rmse|_err|dist|mean_abs")
_WARNING = re.compile(r"\b[A-Za-z]*Warning: ")
UNCHECKED = ("paper", "provenance")
"""Top-level summary keys whose nulls are not scores."""


def read_summary(summary: Path) -> dict[str, Any] | str:
    """The summary as a dict, or why it is not one."""
    try:
        data = json.loads(summary.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return f"no readable summary.json ({type(exc).__name__})"
    return data if isinstance(data, dict) else "summary.json is not an object"


def leaves(obj: Any, path: str = "") -> list[tuple[str, Any]]:
    """``(dotted path, value)`` of every scalar below ``obj``."""
    if isinstance(obj, dict):
        return [x for k, v in obj.items() for x in leaves(v, f"{path}.{k}" if path else k)]
    if isinstance(obj, list):
        return [x for i, v in enumerate(obj) for x in leaves(v, f"{path}[{i}]")]
    return [(path, obj)]


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def degenerate_reason(summary: Path) -> str | None:
    """Why a successful run's ``summary.json`` is not a real score, or ``None``."""
    data = read_summary(summary)
    if isinstance(data, str):
        return data
    if not data.get("filters"):
        return "no filter results in summary.json"
    for path, v in leaves({k: v for k, v in data.items() if k != "paper"}):
        if _num(v) and not math.isfinite(v):
            return f"non-finite value {path} = {v}"
    if "poses" in data and _num(data["poses"]) and data["poses"] < 2:
        return f"a log of {data['poses']} pose(s) presented as scored"
    groups = ("filters", "baselines", "reference")
    # a dead-reckoning baseline (odometry, imu_only) on noise-free readings (every σ
    # 1e-160) integrates exactly: all its errors 0 is a true score, not a degenerate one
    baselines = set(data.get("baselines") or {})
    for name, entry in ((n, e) for g in groups for n, e in (data.get(g) or {}).items()):
        if not isinstance(entry, dict):
            continue
        metrics = [(p, v) for p, v in leaves(entry) if _METRIC.search(p) and _num(v)]
        if entry.get("runs_scored", 1) == 0 and metrics:
            return f"{name}: 0 runs scored but {metrics[0][0]} = {metrics[0][1]}"
        if metrics and all(v == 0 for _, v in metrics) and name not in baselines:
            return f"{name}: every error metric is exactly 0 ({len(metrics)} of them)"
        if entry.get("landmarks_mapped") == 0 and any("landmark" in p for p, _ in metrics):
            return f"{name}: 0 landmarks mapped but landmark distances reported"
    return None


# --------------------------------------------------------------------------- nulls

Key = str | int
Explainer = Callable[[list[Any], list[Key]], bool]
"""``(containers from the root down to the null's parent, the keys on the way) -> the
null is explained``."""

COUNT = re.compile(r"^(n|count|epochs|samples|logs|updates|runs_scored|converged_runs)$"
                   r"|_(count|epochs|samples)$|^n_")
"""Names of keys that count what a statistic is computed over (not ``diverged_runs``)."""


def _has_reason(chain: list[Any], keys: list[Key]) -> bool:
    """A ``<key>_reason`` string beside the null (or beside the list holding it), or a
    ``reason`` string in the same table."""
    for depth in (len(chain) - 1, len(chain) - 2):
        if depth < 0 or not isinstance(chain[depth], dict):
            continue
        key = keys[depth]
        if isinstance(key, str):
            why = chain[depth].get(f"{key}_reason")
            if isinstance(why, str) and why.strip():
                return True
    parent = chain[-1]
    return isinstance(parent, dict) and isinstance(parent.get("reason"), str) \
        and bool(parent["reason"].strip())


def _zero_count(chain: list[Any], keys: list[Key]) -> bool:
    """A count key equal to 0 in the null's table or in one of the two around it."""
    for table in chain[-3:]:
        if isinstance(table, dict) and any(
                COUNT.search(str(k)) and _num(v) and v == 0 for k, v in table.items()):
            return True
    return False


def _false_flag(chain: list[Any], keys: list[Key]) -> bool:
    """A sibling ``false`` that names the same quantity (``azimuth_observable: false``
    beside ``azimuth_limit_deg: null``): the value does not exist, and says so."""
    parent, key = chain[-1], keys[-1]
    if not (isinstance(parent, dict) and isinstance(key, str)):
        return False
    stem = key.split("_")[0]
    return any(v is False and k != key and str(k).split("_")[0] == stem
               for k, v in parent.items())


NULL_EXPLAINERS: tuple[Explainer, ...] = (_has_reason, _zero_count, _false_flag)
"""The rules that explain a null; a null none of them explains is reported."""


def unexplained_nulls(data: dict[str, Any],
                      explainers: tuple[Explainer, ...] = NULL_EXPLAINERS) -> list[str]:
    """Dotted paths of the nulls in a summary that no explainer explains."""
    out: list[str] = []

    def visit(v: Any, chain: list[Any], keys: list[Key], path: str) -> None:
        if v is None:
            if not any(e(chain, keys) for e in explainers):
                out.append(path)
            return
        items = v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) \
            else ()
        for k, x in items:
            sub = f"{path}[{k}]" if isinstance(k, int) else (f"{path}.{k}" if path else k)
            visit(x, [*chain, v], [*keys, k], sub)

    for k, v in data.items():
        if k not in UNCHECKED:
            visit(v, [data], [k], k)
    return out


_GROUP = re.compile(r"^(filters|reference|baselines)\.[^.\[]+")


def null_pattern(path: str) -> str:
    """A null's path with list indices and filter names made ``*``, to count alike ones."""
    return _GROUP.sub(r"\1.*", re.sub(r"\[\d+\]", "[*]", path))


# --------------------------------------------------------------------------- stderr

def printed_warnings(stderr: str) -> list[str]:
    """The ``SomethingWarning: ...`` lines on stderr (numpy's RuntimeWarnings ...)."""
    return [ln.strip() for ln in stderr.splitlines() if _WARNING.search(ln)]
