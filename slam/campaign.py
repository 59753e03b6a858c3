"""Monte Carlo campaigns: one task function per run, any executor.

Each world ``kind`` registers a :class:`Scenario`: ``run_once(world, run, seed_seq,
filters, keep_tracks)`` simulates and scores one run, ``summarize(world, outcomes,
filters, runs, seed)`` builds the ``summary.json`` dict.  :func:`run_campaign` maps
the run function over a local process pool (in-process with ``workers=1``, or any
``map``-like executor) and summarises.  Each worker pins its maths library to one
thread; seeds come from ``numpy.random.SeedSequence(seed).spawn``, so the result does
not depend on the executor or the number of workers.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from .attitude_scenario import run_once as attitude_run_once
from .attitude_scenario import summarize_attitude
from .drone_scenario import run_once as drone_run_once
from .drone_scenario import summarize_drone
from .planar_scenario import run_once as planar_run_once
from .planar_scenario import summarize_planar
from .results import CampaignResult, RunOutcome


@dataclass(frozen=True)
class Scenario:
    """How to run and summarise one world kind."""

    run_once: Callable[..., RunOutcome]
    summarize: Callable[..., dict]


SCENARIOS: dict[str, Scenario] = {
    "planar-slam": Scenario(planar_run_once, summarize_planar),
    "attitude": Scenario(attitude_run_once, summarize_attitude),
    "drone-slam": Scenario(drone_run_once, summarize_drone),
}


def pin_threads() -> None:
    """One BLAS/OpenMP thread per worker process (two processes on two cores with
    default threading were measured swinging 0.5 s - 9 s on the same run)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def run_seeds(seed: int, runs: int) -> list[np.random.SeedSequence]:
    """Independent, reproducible seed sequences, one per run."""
    return np.random.SeedSequence(seed).spawn(runs)


def run_task(args: tuple) -> RunOutcome:
    """The one task function every executor runs: ``(world, run, seed_seq, filters,
    keep_tracks)`` -> :class:`RunOutcome`.  It pins the maths library to one thread
    itself, so a run computes the same bits in a local pool or on a Dask worker."""
    from threadpoolctl import threadpool_limits

    world = args[0]
    with threadpool_limits(1):
        return SCENARIOS[world.kind].run_once(*args)


def dask_mapper(address: str):
    """A ``mapper`` for :func:`run_campaign` over a Dask distributed scheduler.

    Returns ``(mapper, client)``; close the client when done.  Results are yielded as
    they complete (feeding the progress bar); the campaign sorts them by run.
    """
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:  # the [dask] extra is not installed
        raise RuntimeError("--scheduler needs the [dask] extra: "
                           "pip install -e '.[dask]'") from exc
    client = Client(address)

    def mapper(fn, tasks):
        futures = client.map(fn, list(tasks), pure=False)
        for fut in as_completed(futures):
            yield fut.result()

    return mapper, client


def campaign_tasks(world, filters: Sequence[str], runs: int, seed: int) -> list[tuple]:
    """The task arguments of a campaign (run 0 keeps full tracks for the plots)."""
    return [(world, i, s, list(filters), i == 0) for i, s in enumerate(run_seeds(seed, runs))]


def run_campaign(world, *, filters: Sequence[str] | None = None, runs: int | None = None,
                 seed: int | None = None, workers: int = 1,
                 mapper: Callable[[Callable, Iterable], Iterable] | None = None,
                 progress: Callable[[int], None] | None = None) -> CampaignResult:
    """Run a Monte Carlo campaign on ``world``.

    Parameters
    ----------
    filters, runs, seed : default to the world's.
    workers : processes of the local pool (1 = in this process).
    mapper : an alternative ``map(fn, iterable)`` (e.g. over a Dask cluster);
        overrides ``workers``.  Results may arrive in any order.
    progress : called with 1 after each finished run.
    """
    if world.kind not in SCENARIOS:
        raise ValueError(f"no scenario runner for world kind {world.kind!r}")
    filters = list(filters or world.filters.names)
    runs = int(runs or world.runs)
    seed = int(world.seed if seed is None else seed)
    tasks = campaign_tasks(world, filters, runs, seed)
    outcomes: list[RunOutcome] = []
    pool = None
    if mapper is not None:
        it = mapper(run_task, tasks)
    elif workers <= 1:
        pin_threads()
        it = map(run_task, tasks)
    else:
        pool = ProcessPoolExecutor(max_workers=workers, initializer=pin_threads)
        it = pool.map(run_task, tasks)
    try:
        for out in it:
            outcomes.append(out)
            if progress:
                progress(1)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    outcomes.sort(key=lambda o: o.run)
    summary = SCENARIOS[world.kind].summarize(world, outcomes, filters, runs, seed)
    return CampaignResult(world, summary, outcomes)
