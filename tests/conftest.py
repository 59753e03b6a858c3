"""Shared pytest configuration.

Layout: ``tests/`` mirrors the packages (``tests/estimators``, ``tests/nav``,
``tests/slam`` with ``tests/slam/kinds/<kind>``, ``tests/worlds``).  Every folder is a
package (it has an ``__init__.py``), so pytest imports a test file by its dotted name
(``tests.slam.test_cli``, ``tests.slam.kinds.recorded.test_cli``): basenames may repeat
across folders, and ``tests/`` itself is never put on ``sys.path`` (a ``tests/nav``
package there would shadow the real ``nav``).  Shared helpers are imported as
``tests.<module>`` (``tests.small_worlds``, ``tests.linear_model``); pytest puts the
repository root on ``sys.path`` for that, so no ``pythonpath`` setting is needed.
"""

import gc
import logging
import os

import pytest

# one BLAS thread per test process keeps timings and rounding reproducible
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")


def pytest_collection_finish(session) -> None:
    """Move what collection imported (numpy, scipy, gtsam, the project, hypothesis) out of
    the garbage collector's reach: its full collections then walk only what the tests
    create (about half of their 5 s over the suite)."""
    gc.collect()
    gc.freeze()


@pytest.fixture(autouse=True)
def _no_library_log_warnings(caplog):
    """A matplotlib warning sent through ``logging`` (not ``warnings``, which the
    ``filterwarnings`` setting already makes an error) fails the test: the terminal shows
    no library warnings ("Ignoring fixed y limits ..." once reached it)."""
    yield
    logged = [f"{r.name}: {r.getMessage()}" for r in caplog.get_records("call")
              if r.name.startswith("matplotlib") and r.levelno >= logging.WARNING]
    assert not logged, f"library warnings logged: {logged}"
