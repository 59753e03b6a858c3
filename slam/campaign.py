"""Monte Carlo campaigns: one task function per run, any executor.

Each world ``kind`` is a :class:`~slam.kind.Kind` in the registry (:mod:`slam.kinds`):
``run_once(world, run, seed_seq, filters, keep_tracks)`` simulates and scores one run,
``summarize(world, outcomes, filters, runs, seed)`` builds the ``summary.json`` dict.
:func:`run_campaign` maps the run function over a local process pool (in-process with
``workers=1``, or any ``map``-like executor) and summarises.  Each worker pins its maths
library to one thread; seeds come from ``numpy.random.SeedSequence(seed).spawn``, so the result does
not depend on the executor or the number of workers.

Stopping: a local pool's workers die with the campaign's process (even a SIGKILL to it
alone; :func:`die_with_parent`) and leave SIGINT to it; an error or Ctrl-C in the
campaign kills the runs still in flight at once (:func:`stop_pool`).  An exception
raised in a run (e.g. a :class:`~worlds.schema.WorldError` found while driving the
path) reaches the caller as itself: the errors the command line turns into exit 2
pickle with their arguments.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any

import numpy as np

from estimators.loop import set_epoch_hook
from slam.registry import KINDS
from slam.results import CampaignResult, RunOutcome


def pin_threads() -> None:
    """One BLAS/OpenMP thread per worker process (two processes on two cores with
    default threading were measured swinging 0.5 s - 9 s on the same run)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def die_with_parent(parent: int) -> None:
    """End this (worker) process when process ``parent`` dies: ``PR_SET_PDEATHSIG`` on
    Linux, a watchdog thread polling the parent elsewhere."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) != 0:  # 1 = PR_SET_PDEATHSIG
            raise OSError(ctypes.get_errno(), "prctl failed")
    except (OSError, AttributeError):
        def watch() -> None:
            while os.getppid() == parent:
                threading.Event().wait(0.5)
            os._exit(1)

        threading.Thread(target=watch, daemon=True, name="parent-watch").start()
    if os.getppid() != parent:  # the parent died before the watch was set up
        os._exit(1)


def count_epochs(counter: Any) -> None:
    """Add every filter epoch this process runs to the shared ``counter`` (a
    ``multiprocessing.Value``) for the progress display."""
    def tick() -> None:
        with counter.get_lock():
            counter.value += 1

    set_epoch_hook(tick)


def init_worker(parent: int, counter: Any = None) -> None:
    """A pool worker: dies with the campaign's process, leaves SIGINT to it (the parent
    stops the pool on Ctrl-C), pins its maths library to one thread and counts its filter
    epochs into ``counter`` (if given)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # blocked while the parent forked us
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    die_with_parent(parent)
    pin_threads()
    if counter is not None:
        count_epochs(counter)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: kill its workers (in-flight runs included), cancel the rest."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for proc in procs:
        if proc.is_alive():
            proc.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        proc.join(timeout=2.0)


@contextmanager
def stop_signals_blocked() -> Iterator[None]:
    """SIGINT/SIGTERM blocked in this (main) thread within the block, so pool workers
    forked there start with them blocked (:func:`init_worker` unblocks them); a signal
    arriving meanwhile is delivered to this process afterwards."""
    mask = hasattr(signal, "pthread_sigmask") and threading.current_thread() is \
        threading.main_thread()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS) if mask else None
    try:
        yield
    finally:
        if old is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _pool_results(pool: ProcessPoolExecutor, tasks: list[tuple],
                  fn: Callable[[tuple], Any] | None = None) -> Iterator:
    """``pool.map(fn, tasks)`` (default :func:`run_task`), the workers forked with the stop
    signals blocked (:func:`stop_signals_blocked`)."""
    with stop_signals_blocked():
        return pool.map(fn or run_task, tasks)


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
        return KINDS[world.kind].run_once(*args)


def run_task_batch(args: tuple) -> list[RunOutcome]:
    """The batched task: ``(world, runs, seed_seqs, filters, keep_first)`` -> the runs'
    outcomes (:class:`~slam.kind.RunBatch`), one maths thread as :func:`run_task`."""
    from threadpoolctl import threadpool_limits

    world = args[0]
    with threadpool_limits(1):
        return KINDS[world.kind].run_batch(*args)


BATCH = 25
"""Runs per batched task by default.  The chunks do not depend on the executor or the
number of workers, so a campaign gives the same bits on any of them (a different batch size
changes results only at round-off: the members of a batch are computed together)."""

EXECUTORS = ("batched", "per-run")
"""How a campaign runs its runs: ``batched`` (chunks of runs through the filters at once,
where the kind has the batched path) or ``per-run`` (one run per task, the reference)."""


def batch_chunks(runs: int, batch: int | None = None) -> list[range]:
    """Consecutive chunks of the run indices, ``batch`` (default :data:`BATCH`) runs each."""
    size = batch or BATCH
    return [range(i, min(i + size, runs)) for i in range(0, runs, size)]


def pool_size(world, runs: int, workers: int, executor: str = "batched",
              batch: int | None = None) -> int:
    """The local processes a campaign uses: ``workers``, but no more than it has tasks
    (runs, or chunks of runs on the batched path)."""
    batched = executor == "batched" and KINDS[world.kind].run_batch is not None
    tasks = len(batch_chunks(runs, batch)) if batched else runs
    return max(1, min(workers, tasks))


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


def campaign_tasks(world, filters: Sequence[str], runs: int, seed: int,
                   keep_all: bool = False) -> list[tuple]:
    """The task arguments of a campaign (run 0 keeps full tracks for the plots; every run
    with ``keep_all``)."""
    return [(world, i, s, list(filters), keep_all or i == 0)
            for i, s in enumerate(run_seeds(seed, runs))]


def batch_tasks(world, filters: Sequence[str], runs: int, seed: int,
                batch: int | None = None) -> list[tuple]:
    """The batched task arguments: chunks of runs (:func:`batch_chunks`) with their seeds
    (the same seed per run as :func:`campaign_tasks`)."""
    seeds = run_seeds(seed, runs)
    return [(world, list(c), [seeds[i] for i in c], list(filters), True)
            for c in batch_chunks(runs, batch)]


def _count(counter: Any) -> int:
    """The counter's value read without its lock: a worker killed while holding the lock
    (Ctrl-C stops the pool at once) must not block the reader."""
    return int(counter.get_obj().value)


def _poll(counter: Any, report: Callable[[int], None], done: threading.Event) -> None:
    """``report`` of the count every half second until ``done``."""
    while not done.wait(0.5):
        report(_count(counter))


def run_campaign(world, *, filters: Sequence[str] | None = None, runs: int | None = None,
                 seed: int | None = None, workers: int = 1,
                 mapper: Callable[[Callable, Iterable], Iterable] | None = None,
                 progress: Callable[[int], None] | None = None,
                 epochs: Callable[[int], None] | None = None, executor: str = "batched",
                 batch: int | None = None, keep_all: bool = False) -> CampaignResult:
    """Run a Monte Carlo campaign on ``world``.

    Parameters
    ----------
    filters, runs, seed : default to the world's.
    workers : processes of the local pool (1 = in this process).
    mapper : an alternative ``map(fn, iterable)`` (e.g. over a Dask cluster);
        overrides ``workers``.  Results may arrive in any order.
    progress : called with 1 after each finished run.
    epochs : called about twice a second from another thread with the number of filter
        epochs run so far (all filters, all runs; not with ``mapper``), so that progress
        moves within a run.
    executor : ``"batched"`` (chunks of ``batch`` runs through the filters at once, where
        the kind has a batched path; the default) or ``"per-run"`` (:data:`EXECUTORS`).
        Both give the same summary to round-off (``tests/slam/test_batch_campaign.py``).
    keep_all : every run keeps its full tracks (``slam run --tum all``), not only run 0;
        the runs go the per-run path.
    """
    if world.kind not in KINDS:
        raise ValueError(f"no scenario kind {world.kind!r} is registered")
    filters = list(filters or world.filters.names)
    runs = int(runs or world.runs)
    seed = int(world.seed if seed is None else seed)
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; choose from {', '.join(EXECUTORS)}")
    batched = (executor == "batched" and KINDS[world.kind].run_batch is not None
               and not keep_all)
    if batched:
        fn: Callable = run_task_batch
        tasks = batch_tasks(world, filters, runs, seed, batch)
    else:
        fn, tasks = run_task, campaign_tasks(world, filters, runs, seed, keep_all)
    outcomes: list[RunOutcome] = []
    pool = None
    workers = min(workers, len(tasks))
    counter = multiprocessing.Value("q", 0) if epochs is not None and mapper is None else None
    if mapper is not None:
        it = mapper(fn, tasks)
    elif workers <= 1:
        pin_threads()
        if counter is not None:
            count_epochs(counter)
        it = map(fn, tasks)
    else:
        pool = ProcessPoolExecutor(max_workers=workers, initializer=init_worker,
                                   initargs=(os.getpid(), counter))
        it = _pool_results(pool, tasks, fn)
    done = threading.Event()
    if counter is not None and epochs is not None:
        threading.Thread(target=_poll, args=(counter, epochs, done), daemon=True,
                         name="epoch-progress").start()
    try:
        for out in it:
            got = out if isinstance(out, list) else [out]
            outcomes.extend(got)
            if progress:
                progress(len(got))
    except BaseException:  # an error, Ctrl-C: no waiting for the runs still going
        done.set()
        if pool is not None:
            stop_pool(pool)
            pool = None
        raise
    finally:
        done.set()
        if counter is not None and workers <= 1:
            set_epoch_hook(None)
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    if counter is not None and epochs is not None:
        epochs(_count(counter))  # the final count, however short the campaign
    outcomes.sort(key=lambda o: o.run)
    summary = KINDS[world.kind].summarize(world, outcomes, filters, runs, seed)
    return CampaignResult(world, summary, outcomes)
