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


# ---------------------------------------------------------------- the import-time default

_PROBE = """
import json, sys, warnings
warnings.simplefilter("always")
with warnings.catch_warnings(record=True) as caught:
    {imports}
from threadpoolctl import threadpool_info
{after}
print(json.dumps({{"blas": [p["num_threads"] for p in threadpool_info()
                            if p["user_api"] == "blas"],
                  "warnings": [str(w.message) for w in caught]}}))
"""


def _probe(imports: str, env: dict[str, str], after: str = "") -> dict:
    import json
    import os
    import subprocess
    import sys

    full = {k: v for k, v in os.environ.items()
            if k not in ("NAVFILTERS_BLAS_THREADS", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                         "MKL_NUM_THREADS")}
    full.update({"OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2", **env})
    out = subprocess.run([sys.executable, "-c", _PROBE.format(imports=imports, after=after)],
                         env=full, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


@pytest.fixture(scope="module")
def baseline() -> list[int]:
    b = _probe("import numpy, scipy.linalg", {})["blas"]
    if not b or max(b) < 2:
        pytest.skip("this BLAS cannot run two threads here; nothing to cap")
    return b


def test_importing_the_library_pins_blas_to_one_thread(baseline) -> None:
    for module in ("estimators", "nav", "nav.ins"):
        got = _probe(f"import {module}", {})
        assert got["blas"] == [1] * len(baseline), module
        assert got["warnings"] == []


def test_the_opt_outs(baseline) -> None:
    assert _probe("import estimators", {"NAVFILTERS_BLAS_THREADS": "keep"})["blas"] == baseline
    released = _probe("import estimators", {},
                      "from estimators.threads import release_blas_threads\n"
                      "release_blas_threads()\nrelease_blas_threads()")
    assert released["blas"] == baseline


def test_a_bad_setting_pins_one_thread_and_says_so(baseline) -> None:
    got = _probe("import estimators", {"NAVFILTERS_BLAS_THREADS": "lots"})
    assert got["blas"] == [1] * len(baseline)
    assert len(got["warnings"]) == 1
    assert "NAVFILTERS_BLAS_THREADS='lots'" in got["warnings"][0]
