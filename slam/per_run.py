"""Per-run figures for ``summary.json`` (``per_run``): each estimator's summary metrics on
every run alone, so that a table can be re-derived (and a run's outliers found) outside
the workbench.

The kind's own summary function is applied to one run at a time (the campaign statistics
of a one-run campaign: its RMSEs, ANEES, NIS, times); the numbers, and tables of numbers
(per-axis errors), are kept, non-finite values left out, and the run's divergence and its
reason added.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from slam.registry import KINDS
from slam.results import RunOutcome

GROUPS = ("filters", "reference", "baselines")


def _plain(v: Any) -> Any:
    """``v`` if a finite number or a table of finite numbers (others left out: None)."""
    if isinstance(v, bool) or v is None:
        return None
    if isinstance(v, int | float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        out = {k: x for k, x in ((k, _plain(x)) for k, x in v.items()) if x is not None
               and not isinstance(x, dict)}
        return out or None
    return None


def per_run(world: Any, outcomes: Sequence[RunOutcome], filters: Sequence[str],
            seed: int) -> dict[str, list[dict[str, Any]]]:
    """``{estimator: [{"run": r, "diverged": ..., <metric>: ...}, ...]}`` over the runs."""
    kind = KINDS[world.kind]
    out: dict[str, list[dict[str, Any]]] = {}
    for o in outcomes:
        one = kind.summarize(world, [o], list(filters), 1, seed)
        for group in GROUPS:
            for name, entry in (one.get(group) or {}).items():
                if not isinstance(entry, dict):
                    continue
                s = o.scores.get(name)
                row: dict[str, Any] = {"run": o.run}
                diverged = bool(getattr(s, "diverged", entry.get("diverged", False)))
                row["diverged"] = diverged
                if diverged:
                    row["failure"] = str(getattr(s, "failure", None) or entry.get("failure")
                                         or "diverged")
                for k, v in entry.items():
                    if k in ("runs_scored", "diverged_runs", "diverged", "failure"):
                        continue
                    p = _plain(v)
                    if p is not None:
                        row[k] = p
                out.setdefault(name, []).append(row)
    return out
