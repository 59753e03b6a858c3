"""Draw a report's figures in worker processes, several at once.

After a campaign the local workers are idle, and each figure is an independent,
single-threaded matplotlib draw of the finished result.  :func:`draw_figures` forks up to
``workers`` processes that inherit the result (nothing is pickled but the figure's
name), each drawing whole figures into the output folder; the parent reads the files
back in the kinds' order.  With one worker, or where ``fork`` is not available
(macOS and Windows start processes by ``spawn``, which would have to pickle the result),
the figures are drawn here one after another - the same files either way.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Mapping
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

Plot = Callable[[Any, Path], None]

#: The job the forked workers draw from (set only while a pool is running).
_JOB: dict[str, Any] = {}


def _draw(name: str) -> str:
    """Worker: draw figure ``name`` of the inherited job into its file."""
    _JOB["plots"][name](_JOB["result"], _JOB["out_dir"] / name)
    return name


def can_fork() -> bool:
    """True where worker processes can be forked (they then inherit the result)."""
    return "fork" in multiprocessing.get_all_start_methods()


def draw_figures(result: Any, plots: Mapping[str, Plot], out_dir: Path, workers: int = 1,
                 progress: Callable[[str, int, int], None] | None = None) -> dict[str, bytes]:
    """Draw every ``plots[name](result, out_dir / name)`` and return the files' bytes in
    the order of ``plots``; ``progress(name, i, n)`` as each is started (one at a time)
    or finished (``workers`` > 1).  An exception in a figure is raised here."""
    names = list(plots)
    n = len(names)
    workers = min(workers, n)
    if workers <= 1 or not can_fork():
        for i, name in enumerate(names):
            if progress is not None:
                progress(name, i, n)
            plots[name](result, out_dir / name)
    else:
        _in_pool(result, plots, out_dir, workers, progress)
    return {name: (out_dir / name).read_bytes() for name in names}


def _in_pool(result: Any, plots: Mapping[str, Plot], out_dir: Path, workers: int,
             progress: Callable[[str, int, int], None] | None) -> None:
    from slam.campaign import init_worker, stop_pool, stop_signals_blocked

    _JOB.update(result=result, plots=plots, out_dir=out_dir)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=init_worker, initargs=(os.getpid(),))
    try:
        with stop_signals_blocked():  # the workers fork at submit
            pending = {pool.submit(_draw, name) for name in plots}
        done_count = 0
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                name = fut.result()  # a figure's exception is raised here
                done_count += 1
                if progress is not None:
                    progress(name, done_count, len(plots))
    except BaseException:
        stop_pool(pool)
        raise
    else:
        pool.shutdown()
    finally:
        _JOB.clear()
