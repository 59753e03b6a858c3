"""Planar SLAM scenario: one Monte Carlo run and the campaign summary.

:func:`run_once` simulates run ``i`` from its own seed, runs every filter, the
odometry-only baseline and the GTSAM smoother on the same log, and reduces each to
:class:`~slam.results.RunScores`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from slam.decision import decide
from slam.failures import run_reference
from slam.kinds.planar.odometry import interpolate_reference
from slam.kinds.planar.online import OnlineTrack, fixed_lag_planar, online_planar
from slam.kinds.planar.reference import smooth_planar
from slam.kinds.planar.scoring import reduce_run, summarize
from slam.kinds.planar.segments import run_events, segment_summary
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import dead_reckoning_batch, epochs_of, run_slam_batch
from slam.kinds.planar.variants import INVARIANT_BASES
from slam.kinds.planar.world import ONLINE, fixed_lag_name, online_rows
from slam.ranking import Metric, per_run, per_run_mse
from slam.results import ODOMETRY, REFERENCE, RunOutcome, Track
from slam.scoring import landmark_anees_entries


def run_once(world, run: int, seed_seq: np.random.SeedSequence, filters: Sequence[str],
             keep_tracks: bool = False, reference: bool = True) -> RunOutcome:
    """Simulate one run and score every estimator on it (the per-run path)."""
    return run_batch(world, [run], [seed_seq], filters, keep_tracks, reference,
                     batched=False)[0]


def run_batch(world, runs: Sequence[int], seed_seqs: Sequence[np.random.SeedSequence],
              filters: Sequence[str], keep_first: bool = False, reference: bool = True,
              batched: bool = True) -> list[RunOutcome]:
    """Simulate runs ``runs`` (each from its own seed) and score every estimator on each:
    the filters and the odometry run over all of them at once where their layouts agree
    (:func:`~slam.kinds.planar.slam.run_slam_batch`; ``batched=False`` runs them one by
    one), the smoother per run.  ``keep_first`` keeps full tracks of run 0 (if present).
    Every outcome is the one :func:`run_once` gives for that run."""
    logs = [simulate_planar(world, np.random.default_rng(s)) for s in seed_seqs]
    fs = world.filters
    period = world.sensor.period_steps
    steps = [epochs_of(log, period) for log in logs]
    truths = [log.truth[st] for log, st in zip(logs, steps)]
    scores: list[dict] = [{} for _ in logs]
    tracks: list[dict] = [{} for _ in logs]
    keep = [keep_first and (r == 0 or not batched) for r in runs]  # run_once: as asked
    for name in filters:
        results = run_slam_batch(logs, name, association=fs.association,
                                 gates=(fs.gate_accept, fs.gate_new), epoch_steps=period,
                                 mode=fs.mode, filter_params=fs.settings_of(name),
                                 batched=batched)
        for i, (log, r) in enumerate(zip(logs, results)):
            scores[i][name] = reduce_run(name, r.poses, r.pose_cov, truths[i], r.landmark_ids,
                                         r.landmarks, log.landmarks, r.nis, r.nis_dof,
                                         r.time_s, r.diverged, r.failure,
                                         nis_epoch=r.nis_epoch, map_series=r.map_series)
            if keep[i]:
                tracks[i][name] = Track(name, r.poses, r.pose_cov, r.landmark_ids,
                                        r.landmarks, r.landmark_cov)
    for i, (odo, odo_cov, odo_failure, seconds) in enumerate(
            dead_reckoning_batch(logs, steps, batched=batched)):
        lms = logs[i].landmarks
        scores[i][ODOMETRY] = reduce_run(ODOMETRY, odo, odo_cov, truths[i], np.zeros(0, int),
                                         np.zeros((0, 2)), lms, np.zeros(0),
                                         np.zeros(0, int), seconds, odo_failure is not None,
                                         odo_failure)
        if keep[i]:
            tracks[i][ODOMETRY] = Track(ODOMETRY, odo, odo_cov, np.zeros(0, int),
                                        np.zeros((0, 2)), np.zeros((0, 2, 2)))
    out = []
    for i, (run, log) in enumerate(zip(runs, logs)):
        _graph_rows(world, log, steps[i], truths[i], scores[i], tracks[i] if keep[i] else None,
                    reference)
        k = keep[i]
        out.append(RunOutcome(run, scores[i], tracks[i], truths[i] if k else None,
                              log.landmarks if k else None, steps[i] * log.dt if k else None,
                              events=run_events(log, steps[i])))
    return out


def online_names(world) -> list[str]:
    """The online rows a planar world asks for: ``isam2`` (``[filters] online``), then one
    ``fls-<lag>s`` per ``[filters] fixed_lags_s``."""
    return online_rows(world.filters)


def _graph_rows(world, log, steps, truth, scores: dict, tracks: dict | None,
                reference: bool) -> None:
    """The rows from the factor graph: the online rows the world asks for and the GTSAM
    smoother (from the online row's own iSAM2 pass when there is one, else the chunked
    path).  A numerical failure marks that row diverged on this run with its reason."""
    keep = tracks is not None
    ref = failure = None
    if getattr(world.filters, "online", False):
        both, failure = run_reference(online_planar, log, steps, landmark_cov=keep)
        track, ref = both if both is not None else (None, None)
        _score_track(ONLINE, track, failure, log, steps, truth, scores, tracks)
    for lag in getattr(world.filters, "fixed_lags_s", ()):
        track, why = run_reference(fixed_lag_planar, log, steps, lag, landmark_cov=keep)
        _score_track(fixed_lag_name(lag), track, why, log, steps, truth, scores, tracks)
    if not reference:
        return
    if ref is None and failure is None:
        ref, failure = run_reference(smooth_planar, log)
    _reference(ref, failure, log, steps, truth, scores, tracks)


def _score_track(name: str, track: OnlineTrack | None, failure: str | None, log, steps, truth,
                 scores: dict, tracks: dict | None) -> None:
    """Score an online row like a filter (no NIS: it has no innovations)."""
    if track is None:
        _failed(name, failure, log, steps, truth, scores, tracks)
        return
    s = reduce_run(name, track.poses, track.pose_cov, truth, track.landmark_ids,
                   track.landmarks, log.landmarks, np.zeros(0), np.zeros(0, int), track.time_s,
                   map_series=track.map_series)
    scores[name] = replace(s, steps=len(steps) - 1)
    if tracks is not None:
        lm_cov = (track.landmark_cov if track.landmark_cov is not None
                  else np.full((len(track.landmark_ids), 2, 2), np.nan))
        tracks[name] = Track(name, track.poses, track.pose_cov, track.landmark_ids,
                             track.landmarks, lm_cov)


def _failed(name: str, failure: str | None, log, steps, truth, scores: dict,
            tracks: dict | None) -> None:
    nan = np.full((len(steps), 3), np.nan)
    cov = np.full((len(steps), 3, 3), np.nan)
    scores[name] = reduce_run(name, nan, cov, truth, np.zeros(0, int), np.zeros((0, 2)),
                              log.landmarks, np.zeros(0), np.zeros(0, int), 0.0, True, failure)
    if tracks is not None:
        tracks[name] = Track(name, nan, cov, np.zeros(0, int), np.zeros((0, 2)),
                             np.zeros((0, 2, 2)))


def _reference(ref, failure: str | None, log, steps, truth, scores: dict,
               tracks: dict | None) -> None:
    """The GTSAM smoother's scores (and track); a numerical failure of the smoother
    marks it diverged on this run with its reason (:mod:`slam.failures`)."""
    lms = log.landmarks
    if ref is None:
        _failed(REFERENCE, failure, log, steps, truth, scores, tracks)
        return
    poses = interpolate_reference(ref, log)[steps]
    cov_all = np.full((log.n_steps + 1, 3, 3), np.nan)
    if ref.pose_cov is not None:
        cov_all[ref.epoch_steps] = ref.pose_cov
    cov = cov_all[steps]
    s = reduce_run(REFERENCE, poses, cov, truth, ref.landmark_ids, ref.landmarks, lms,
                   np.zeros(0), np.zeros(0, int), ref.time_s)
    scores[REFERENCE] = replace(s, steps=len(steps) - 1)
    if tracks is not None:
        tracks[REFERENCE] = Track(REFERENCE, poses, cov, ref.landmark_ids, ref.landmarks,
                                  ref.landmark_cov if ref.landmark_cov is not None
                                  else np.full((len(ref.landmark_ids), 2, 2), np.nan))


def summarize_planar(world, outcomes: list[RunOutcome], filters: list[str], runs: int,
                     seed: int) -> dict:
    """The ``summary.json`` dict of a planar SLAM campaign, with each filter's landmark
    ANEES (:func:`slam.scoring.landmark_anees_entries`), the paired ranking of the filters
    by position and landmark MSE and the headline (:func:`slam.decision.decide`)."""
    online = online_names(world)
    names = filters + online + [ODOMETRY, REFERENCE]
    entries = {n: summarize([o.scores[n] for o in outcomes]) for n in names}
    for n in filters + online:
        entries[n].update(landmark_anees_entries([
            o.scores[n].map_series for o in outcomes
            if not o.scores[n].diverged and o.scores[n].map_series is not None]))
    summary = {
        "world": world.name,
        "kind": world.kind,
        "runs": runs,
        "seed": seed,
        "mode": world.filters.mode,
        "filters": {n: entries[n] for n in filters},
        **({"online": {n: entries[n] for n in online}} if online else {}),
        "baselines": {ODOMETRY: entries[ODOMETRY]},
        "reference": {REFERENCE: entries[REFERENCE]},
        "segments": segment_summary(outcomes, filters + online),
        "paper": world.paper,
    }
    ranked = filters + [REFERENCE]
    metrics = [
        Metric("position", "position", "m", {n: per_run(outcomes, n, lambda s: float(
            per_run_mse(s.err[None, :, :2])[0])) for n in ranked}),
        Metric("landmarks", "landmarks (final)", "m", {n: per_run(outcomes, n, lambda s: float(
            np.mean(s.lm_err**2)) if s.lm_err.size else np.nan) for n in ranked}),
    ]
    fs = world.filters
    return decide(summary, metrics, filters=filters,
                  tuned=fs,
                  variants={b: f"{b}-inv" for b in INVARIANT_BASES})
