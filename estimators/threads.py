"""Run filters with one BLAS/OpenMP thread.

A filter step works on matrices of a few to a few dozen rows.  Multi-threaded BLAS only
adds thread hand-offs at that size, and on a loaded machine those hand-offs wait for a
core: with default OpenBLAS threading on a busy 2-core machine one 5-state UKF step took
80-110 ms of wall time instead of 0.3 ms.  The command line pins every worker process to
one thread (``slam.campaign.pin_threads``); a library user filtering their own data
should do the same::

    from estimators.threads import single_thread_blas

    with single_thread_blas():
        for z in data:
            belief = flt.predict(belief, transition, u)
            belief, innovation = flt.update(belief, measurement, z)

It also works as a decorator (``@single_thread_blas()``).  For whole processes (e.g. a
pool's workers), setting ``OPENBLAS_NUM_THREADS=1``, ``OMP_NUM_THREADS=1`` and
``MKL_NUM_THREADS=1`` before numpy is imported has the same effect.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["single_thread_blas"]


@contextmanager
def single_thread_blas() -> Iterator[None]:
    """Limit every BLAS and OpenMP thread pool to one thread inside the ``with`` block.

    Uses :func:`threadpoolctl.threadpool_limits`, which caps the libraries loaded when
    the block is entered; numpy's and scipy's BLAS are loaded first so both are capped.
    A library first loaded inside the block keeps its own default.  The previous limits
    are restored on exit, also after an exception.
    """
    import numpy  # noqa: F401  (load the BLAS libraries before they are capped)
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        yield
