"""estimators.threads.single_thread_blas: one BLAS/OpenMP thread inside, restored after."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS is one of the pools checked)
from threadpoolctl import threadpool_info, threadpool_limits

from estimators.threads import single_thread_blas


def threads(user_api: str = "blas") -> list[int]:
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == user_api]


def two_threads() -> list[int]:
    """Per-pool BLAS threads under an outer limit of two (skip where BLAS cannot use two)."""
    before = threads()
    assert before, "no BLAS library visible to threadpoolctl"
    if max(before) < 2:
        pytest.skip("this BLAS cannot run two threads here; nothing to cap")
    return before


def test_one_thread_inside_and_restored_after() -> None:
    # start from two threads per pool, so the test fails if nothing is capped (the test
    # session's environment already asks OpenBLAS for one thread)
    with threadpool_limits(limits=2):
        before = two_threads()
        with single_thread_blas():
            assert threads() == [1] * len(before)
            assert all(n == 1 for n in threads("openmp"))
            np.linalg.solve(np.eye(50) + 0.1, np.ones(50))  # BLAS still works
        assert threads() == before


def test_restored_after_an_exception() -> None:
    with threadpool_limits(limits=2):
        before = two_threads()
        with pytest.raises(RuntimeError), single_thread_blas():
            assert threads() == [1] * len(before)
            raise RuntimeError("filter failed")
        assert threads() == before


def test_works_as_a_decorator() -> None:
    @single_thread_blas()
    def inside() -> list[int]:
        return threads()

    with threadpool_limits(limits=2):
        before = two_threads()
        seen = inside()
        assert seen == [1] * len(before)
        assert threads() == before
