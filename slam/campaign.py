"""Monte Carlo campaigns: one task function per run, any executor.

:func:`run_once` simulates run ``i`` from its own seed, runs every filter, the
odometry-only baseline and the GTSAM smoother on the same log, and reduces each to
:class:`~slam.results.RunScores`.  :func:`run_campaign` maps it over a local process
pool (or in-process with ``workers=1``) and summarises.  Each worker pins its maths
library to one thread; seeds come from ``numpy.random.SeedSequence(seed).spawn``, so
the result does not depend on the executor or the number of workers.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np

from .joint import dead_reckoning, epochs_of, run_slam
from .reference import interpolate_reference, smooth_planar
from .results import ODOMETRY, REFERENCE, CampaignResult, RunOutcome, Track
from .scoring import reduce_run, summarize
from .simulate import simulate_planar


def _pin_threads() -> None:
    """One BLAS/OpenMP thread per worker process (two processes on two cores with
    default threading were measured swinging 0.5 s - 9 s on the same run)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover - threadpoolctl is a core dependency
        pass


def run_seeds(seed: int, runs: int) -> list[np.random.SeedSequence]:
    """Independent, reproducible seed sequences, one per run."""
    return np.random.SeedSequence(seed).spawn(runs)


def run_once(world, run: int, seed_seq: np.random.SeedSequence, filters: Sequence[str],
             keep_tracks: bool = False, reference: bool = True) -> RunOutcome:
    """Simulate one run and score every estimator on it."""
    rng = np.random.default_rng(seed_seq)
    log = simulate_planar(world, rng)
    lms = log.landmarks
    fs = world.filters
    period = world.sensor.period_steps
    steps = epochs_of(log, period)
    truth = log.truth[steps]
    scores, tracks = {}, {}
    for name in filters:
        r = run_slam(log, name, association=fs.association,
                     gates=(fs.gate_accept, fs.gate_new), epoch_steps=period)
        scores[name] = reduce_run(name, r.poses, r.pose_cov, truth, r.landmark_ids,
                                  r.landmarks, lms, r.nis, r.nis_dof, r.time_s, r.diverged,
                                  r.failure)
        if keep_tracks:
            tracks[name] = Track(name, r.poses, r.pose_cov, r.landmark_ids, r.landmarks,
                                 r.landmark_cov)
    import time

    t0 = time.perf_counter()
    odo, odo_cov = dead_reckoning(log, steps)
    scores[ODOMETRY] = reduce_run(ODOMETRY, odo, odo_cov, truth, np.zeros(0, int),
                                  np.zeros((0, 2)), lms, np.zeros(0), np.zeros(0, int),
                                  time.perf_counter() - t0)
    if keep_tracks:
        tracks[ODOMETRY] = Track(ODOMETRY, odo, odo_cov, np.zeros(0, int), np.zeros((0, 2)),
                                 np.zeros((0, 2, 2)))
    if reference:
        ref = smooth_planar(log)
        poses = interpolate_reference(ref, log)[steps]
        cov_all = np.full((log.n_steps + 1, 3, 3), np.nan)
        if ref.pose_cov is not None:
            cov_all[ref.epoch_steps] = ref.pose_cov
        cov = cov_all[steps]
        s = reduce_run(REFERENCE, poses, cov, truth, ref.landmark_ids, ref.landmarks, lms,
                       np.zeros(0), np.zeros(0, int), ref.time_s)
        scores[REFERENCE] = replace(s, steps=len(steps) - 1)
        if keep_tracks:
            tracks[REFERENCE] = Track(REFERENCE, poses, cov, ref.landmark_ids, ref.landmarks,
                                      ref.landmark_cov if ref.landmark_cov is not None
                                      else np.full((len(ref.landmark_ids), 2, 2), np.nan))
    times = steps * log.dt
    return RunOutcome(run, scores, tracks, truth if keep_tracks else None,
                      lms if keep_tracks else None, times if keep_tracks else None)


def _task(args: tuple) -> RunOutcome:
    return run_once(*args)


def run_campaign(world, *, filters: Sequence[str] | None = None, runs: int | None = None,
                 seed: int | None = None, workers: int = 1,
                 mapper: Callable[[Callable, Iterable], Iterable] | None = None,
                 progress: Callable[[int], None] | None = None) -> CampaignResult:
    """Run a Monte Carlo campaign on a planar SLAM world.

    Parameters
    ----------
    filters, runs, seed : default to the world's.
    workers : processes of the local pool (1 = in this process).
    mapper : an alternative ``map(fn, iterable)`` yielding results in order (e.g. a Dask
        client's); overrides ``workers``.
    progress : called with 1 after each finished run.
    """
    filters = list(filters or world.filters.names)
    runs = int(runs or world.runs)
    seed = int(world.seed if seed is None else seed)
    tasks = [(world, i, s, filters, i == 0) for i, s in enumerate(run_seeds(seed, runs))]
    outcomes: list[RunOutcome] = []
    if mapper is not None:
        it = mapper(_task, tasks)
    elif workers <= 1:
        _pin_threads()
        it = map(_task, tasks)
    else:
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_pin_threads)
        it = pool.map(_task, tasks)
    try:
        for out in it:
            outcomes.append(out)
            if progress:
                progress(1)
    finally:
        if mapper is None and workers > 1:
            pool.shutdown(cancel_futures=True)
    outcomes.sort(key=lambda o: o.run)
    names = filters + [ODOMETRY, REFERENCE]
    entries = {n: summarize([o.scores[n] for o in outcomes]) for n in names}
    summary = {
        "world": world.name,
        "kind": world.kind,
        "runs": runs,
        "seed": seed,
        "filters": {n: entries[n] for n in filters},
        "baselines": {ODOMETRY: entries[ODOMETRY]},
        "reference": {REFERENCE: entries[REFERENCE]},
        "paper": world.paper,
    }
    return CampaignResult(world, summary, outcomes)
