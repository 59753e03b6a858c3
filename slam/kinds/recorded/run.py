"""A recorded log as a campaign of one run: the world value, the run and its summary.

``slam run --log FILE`` opens the log as a :class:`RecordedWorld` (:func:`open_log`) and
runs it through the same campaign, summary and report path as every other kind.  A log
is one run; there is no randomness, so the seed is unused.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from slam.kinds.recorded.scoring import run_log
from slam.kinds.recorded.tracks import log_tracks
from slam.kinds.recorded.world import KIND, RecordedWorld
from slam.results import RunOutcome

_GROUPS = ("filters", "baselines", "reference")


@dataclass(frozen=True)
class RecordedScores:
    """One estimator's entry of a recorded-log run: its group in the summary
    (filters / baselines / reference) and its values."""

    name: str
    group: str
    values: dict[str, Any]
    diverged: bool = False
    failure: str | None = None


def run_once(world: RecordedWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False) -> RunOutcome:
    """Run the filters and the smoother on the log (the seed is unused).  With
    ``keep_tracks`` the outcome's tracks are every estimator's
    :class:`~slam.mapping.problem.SlamResult` (:func:`~slam.kinds.recorded.tracks.log_tracks`)
    and ``times`` the chain indices of the poses (a log has no clock)."""
    kept: dict[str, Any] | None = {} if keep_tracks else None
    s = run_log(world.log, list(filters), mode=world.filters.mode, keep=kept,
                settings={n: world.filters.settings_of(n) for n in filters})
    scores = {name: RecordedScores(name, group, entry, bool(entry.get("diverged", False)),
                                   entry.get("failure"))
              for group in _GROUPS for name, entry in s[group].items()}
    if kept is None:
        return RunOutcome(run, scores)
    return RunOutcome(run, scores, log_tracks(world.log, kept),  # type: ignore[arg-type]
                      times=np.arange(world.log.n_poses, dtype=float))


def summarize(world: RecordedWorld, outcomes: list[RunOutcome], filters: list[str],
              runs: int, seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a recorded-log run."""
    log = world.log
    out: dict[str, Any] = {
        "log": Path(log.source).name,
        "source": log.source,
        "mode": world.filters.mode,
        "poses": log.n_poses,
        "landmarks": int(len(log.landmark_ids)),
        "observations": int(len(log.obs_id)),
    }
    scores = outcomes[0].scores
    for group in _GROUPS:
        out[group] = {n: s.values for n, s in scores.items() if s.group == group}
    out["kind"] = KIND
    out["world"] = world.name
    return out
