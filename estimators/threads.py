"""Run filters with one BLAS/OpenMP thread - by default.

A filter step works on matrices of a few to a few dozen rows.  Multi-threaded BLAS only
adds thread hand-offs at that size, and on a loaded machine those hand-offs wait for a
core: with default OpenBLAS threading on a busy 2-core machine one 5-state UKF step took
80-110 ms of wall time instead of 0.3 ms.  So importing :mod:`estimators` (which
:mod:`nav` and the workbench's filters import) limits the BLAS and OpenMP pools already
loaded - numpy's and scipy's - to one thread (:func:`pin_by_default`): a library user
filtering their own data never meets that slowdown.

Opting out: set ``NAVFILTERS_BLAS_THREADS`` before the import - ``keep`` leaves the
libraries' own thread counts alone, a positive integer ``N`` limits them to ``N`` - or call
:func:`release_blas_threads` afterwards (it restores the limits found at import, e.g.
before a large matrix product in the same process).  :func:`single_thread_blas` pins
inside a ``with`` block (or as a decorator, ``@single_thread_blas()``) whatever the
process-wide setting::

    from estimators.threads import single_thread_blas

    with single_thread_blas():
        for z in data:
            belief = flt.predict(belief, transition, u)
            belief, innovation = flt.update(belief, measurement, z)

The command line pins every worker process too (``slam.campaign.pin_threads``); for whole
processes, ``OPENBLAS_NUM_THREADS=1``, ``OMP_NUM_THREADS=1`` and ``MKL_NUM_THREADS=1``
before numpy is imported have the same effect.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["ENV", "pin_by_default", "release_blas_threads", "single_thread_blas"]

ENV = "NAVFILTERS_BLAS_THREADS"
"""The environment variable of the opt-out (module docstring)."""
_PINNED: list = []  # the threadpool_limits object of pin_by_default, while it holds


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


def _limit(value: str | None) -> int | None:
    """The thread limit ``NAVFILTERS_BLAS_THREADS`` asks for (``None``: keep); a value
    that is neither gives one thread and a warning that says so."""
    if value is None or value.strip() == "":
        return 1
    v = value.strip().lower()
    if v == "keep":
        return None
    if v.isdigit() and int(v) > 0:
        return int(v)
    import warnings

    warnings.warn(f"{ENV}={value!r} is not 'keep' or a positive integer: BLAS limited to "
                  "one thread", RuntimeWarning, stacklevel=3)
    return 1


def pin_by_default() -> None:
    """Limit the loaded BLAS/OpenMP pools as ``NAVFILTERS_BLAS_THREADS`` says (unset: one
    thread); called once when :mod:`estimators` is imported."""
    import os

    limit = _limit(os.environ.get(ENV))
    if limit is None or _PINNED:
        return
    import numpy  # noqa: F401  (load the BLAS libraries before they are capped)
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    _PINNED.append(threadpool_limits(limits=limit))


def release_blas_threads() -> None:
    """Restore the thread limits :func:`pin_by_default` found (no-op when it pinned
    nothing or they are restored already)."""
    while _PINNED:
        _PINNED.pop().restore_original_limits()
