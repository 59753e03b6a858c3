r"""Where the consistency gap sits: pose NEES / 3 per time segment of a planar run.

**Loop closure.**  The run's loop closure is the first sighting of a landmark that was
last seen at least :data:`CLOSURE_GAP_S` seconds earlier (by its true id, whatever the
filters' association): the first time the vehicle sees again a part of the map it left.
Its epoch is the first filter epoch at or after that sighting's step.

**Segments** of a run's filter epochs :math:`e`, with :math:`c` the closure epoch and
:math:`t_e` the epoch times:

- ``before``: :math:`e < c` (the whole run when there is no closure);
- ``window``: :math:`c \le e` and :math:`t_e < t_c +` :data:`WINDOW_S`;
- ``rest``: the epochs after the window.

Per estimator and segment the summary gives the segment's ANEES (the mean over runs and the
segment's epochs of NEES / 3, diverged runs left out), the share of its epochs whose run
average of NEES / 3 lies in the 95 % band of the runs averaged there, the epoch count, and
each estimator's ratio of ANEES to the online optimum's (``isam2``) in the same segment.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slam.kinds.planar.log import PlanarLog
from slam.results import RunOutcome
from slam.scoring import anees_band, pad_stack

#: Shortest gap between two sightings of a landmark that makes the second a loop closure (s).
CLOSURE_GAP_S = 30.0
#: Length of the segment after the loop closure (s).
WINDOW_S = 60.0
SEGMENTS = ("before", "window", "rest")
CLOSURE = "loop_closure_epoch"
WINDOW_END = "window_end_epoch"


def loop_closure_step(log: PlanarLog, gap_s: float = CLOSURE_GAP_S) -> int | None:
    """The step of the first sighting of a landmark last seen ``gap_s`` or more seconds
    before (``None``: no such sighting)."""
    last: dict[int, int] = {}
    gap = gap_s / log.dt
    for k, j in zip(np.asarray(log.obs_step, int), np.asarray(log.obs_id, int)):
        k, j = int(k), int(j)
        if j in last and k - last[j] >= gap - 1e-9:
            return k
        last[j] = k
    return None


def run_events(log: PlanarLog, filter_steps: NDArray[np.int64]) -> dict[str, int]:
    """The loop-closure epoch and the first epoch after its window (indices into
    ``filter_steps``); empty without a closure."""
    k = loop_closure_step(log)
    if k is None:
        return {}
    steps = np.asarray(filter_steps, dtype=np.int64)
    c = int(np.searchsorted(steps, k))
    end = int(np.searchsorted(steps * log.dt, steps[c] * log.dt + WINDOW_S, side="left"))
    return {CLOSURE: c, WINDOW_END: end}


def _masks(events: Sequence[dict[str, int]], E: int) -> dict[str, NDArray[np.bool_]]:
    """(R, E) membership of every segment."""
    e = np.arange(E)[None, :]
    c = np.array([ev.get(CLOSURE, E) for ev in events])[:, None]
    w = np.array([ev.get(WINDOW_END, E) for ev in events])[:, None]
    return {"before": e < c, "window": (e >= c) & (e < w), "rest": e >= w}


def _segment(nees3: NDArray[np.float64], mask: NDArray[np.bool_]) -> dict[str, Any]:
    """ANEES, in-band share and epochs of one segment (``nees3``: (R, E) NEES / 3)."""
    vals = np.where(mask, nees3, np.nan)
    n = np.sum(np.isfinite(vals), axis=0)  # runs averaged at each epoch
    epochs = np.flatnonzero(n > 0)
    if epochs.size == 0:
        return {"epochs": 0}
    mean = np.nansum(vals[:, epochs], axis=0) / n[epochs]
    counts, which = np.unique(n[epochs], return_inverse=True)  # one band per run count
    lo, hi = np.array([anees_band(int(r), 3) for r in counts]).T[:, which]
    inside = (lo <= mean) & (mean <= hi)
    return {"anees": float(np.nanmean(vals[:, epochs])), "in_band": float(np.mean(inside)),
            "epochs": int(epochs.size)}


def segment_summary(outcomes: Sequence[RunOutcome], names: Sequence[str],
                    online: str = "isam2") -> dict[str, Any]:
    """The ``segments`` entry of ``summary.json`` (module docstring)."""
    closures = [o.events[CLOSURE] for o in outcomes if CLOSURE in o.events]
    out: dict[str, Any] = {
        "definition": (f"loop closure: the first sighting of a landmark last seen >= "
                       f"{CLOSURE_GAP_S:g} s before; window: the {WINDOW_S:g} s from it; "
                       "values: NEES / 3 over runs and the segment's epochs"),
        "runs_with_closure": len(closures),
    }
    if closures:
        out["closure_epoch_range"] = [int(min(closures)), int(max(closures))]
    rows: dict[str, Any] = {}
    for name in names:
        good = [o for o in outcomes if name in o.scores and not o.scores[name].diverged]
        if not good:
            continue
        nees3 = pad_stack([o.scores[name].nees for o in good]) / 3.0
        masks = _masks([o.events for o in good], nees3.shape[1])
        rows[name] = {seg: _segment(nees3, masks[seg]) for seg in SEGMENTS}
    if online in rows:
        for row in rows.values():
            row["ratio_to_" + online] = {
                seg: row[seg]["anees"] / rows[online][seg]["anees"] for seg in SEGMENTS
                if "anees" in row[seg] and "anees" in rows[online][seg]}
    out["estimators"] = rows
    return out
