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

from slam.decision import decide
from slam.kinds.recorded.scoring import run_log
from slam.kinds.recorded.tracks import log_tracks
from slam.kinds.recorded.world import KIND, RecordedWorld
from slam.ranking import Metric, per_run
from slam.results import RunOutcome

_GROUPS = ("filters", "online", "baselines", "reference")


@dataclass(frozen=True)
class RecordedScores:
    """One estimator's entry of a recorded-log run: its group in the summary
    (filters / online / baselines / reference) and its values."""

    name: str
    group: str
    values: dict[str, Any]
    diverged: bool = False
    failure: str | None = None


def run_once(world: RecordedWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False) -> RunOutcome:
    """Run the filters and the smoother on the log (the seed is unused), and the online
    row ``isam2`` when the world's filters ask for it (``--online``).  With
    ``keep_tracks`` the outcome's tracks are every estimator's
    :class:`~slam.mapping.problem.SlamResult` (:func:`~slam.kinds.recorded.tracks.log_tracks`)
    and ``times`` the chain indices of the poses (a log has no clock)."""
    kept: dict[str, Any] | None = {} if keep_tracks else None
    s = run_log(world.log, list(filters), mode=world.filters.mode, keep=kept,
                settings={n: world.filters.settings_of(n) for n in filters},
                online=world.filters.online)
    scores = {name: RecordedScores(name, group, entry, bool(entry.get("diverged", False)),
                                   entry.get("failure"))
              for group in _GROUPS for name, entry in s.get(group, {}).items()}
    if kept is None:
        return RunOutcome(run, scores)
    return RunOutcome(run, scores, log_tracks(world.log, kept),  # type: ignore[arg-type]
                      times=np.arange(world.log.n_poses, dtype=float))


AGAINST_SMOOTHER = ("A recorded log has no ground truth: the filters are ranked by their "
                    "difference to the GTSAM smoother's trajectory on the same measurements, "
                    "not by their error.")
"""The first sentence of a recorded log's headline."""


def _squared(key: str):
    def get(s: RecordedScores) -> float:
        v = s.values.get(key)
        return float(v) ** 2 if v is not None else float("nan")
    return get


def smoother_metrics(outcomes: list[RunOutcome], filters: Sequence[str]) -> list[Metric]:
    """The filters' per-run mean squared difference to the smoother's trajectory over
    their epochs: position (m) and heading (deg); NaN for a filter the run did not score."""
    return [Metric("position", "position vs the smoother", "m",
                   {n: per_run(outcomes, n, _squared("pose_rmse_to_ref_m")) for n in filters}),
            Metric("heading", "heading vs the smoother", "deg",
                   {n: per_run(outcomes, n, _squared("heading_rmse_to_ref_deg"))
                    for n in filters})]


def summarize(world: RecordedWorld, outcomes: list[RunOutcome], filters: list[str],
              runs: int, seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a recorded-log run, with the filters ranked by their
    difference to the smoother (:func:`slam.decision.decide`; one run: the ranking orders
    them but claims no significance, :data:`slam.ranking.ONE_RUN`)."""
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
        entries = {n: s.values for n, s in scores.items() if s.group == group}
        if entries or group != "online":
            out[group] = entries
    out["kind"] = KIND
    out["world"] = world.name
    fs = world.filters
    out = decide(out, smoother_metrics(outcomes, filters), filters=filters, consistency=None,
                 reference=None, tuned=fs)
    out["headline"] = f"{AGAINST_SMOOTHER} {out['headline']}"
    return out
