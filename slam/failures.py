"""Numerical failure of the reference smoother: reported like a filter's divergence.

The filters' loop (:mod:`estimators.loop`) turns a numerical failure into a counted
divergence.  The GTSAM smoother runs outside that loop, after every filter, on the same
log; a log it cannot solve (an indeterminate system, a factor GTSAM refuses) must not
lose the filters' results.  :func:`run_reference` runs it and returns the failure as a
reason instead: the kind then records the reference as diverged on that run, and the
summary lists the reason under ``failures``.

What counts as a numerical failure: GTSAM's exceptions (``RuntimeError`` through its
Python binding: ``IndeterminantLinearSystemException``, a ``Symbol`` index too large, a
non-positive-definite noise model ...), numpy's ``LinAlgError`` and floating-point
errors.  A ``RecursionError`` or ``NotImplementedError`` (``RuntimeError`` subclasses
that signal a bug) still escapes, as does everything else.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

T = TypeVar("T")

REFERENCE_FAILURES: tuple[type[BaseException], ...] = (
    RuntimeError, np.linalg.LinAlgError, ArithmeticError)


def reason(exc: BaseException, limit: int = 300) -> str:
    """``"<ExceptionName>: <first sentence of the message>"`` on one line, at most
    ``limit`` characters (GTSAM's messages run over several paragraphs)."""
    words = " ".join(str(exc).split())
    end = words.find(". ")
    text = f"{type(exc).__name__}: {words[:end + 1] if end > 0 else words}".rstrip(": ")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def run_reference(fn: Callable[..., T], *args: Any, **kwargs: Any) -> tuple[T | None, str | None]:
    """``(fn(*args, **kwargs), None)``, or ``(None, reason)`` when it fails numerically."""
    try:
        return fn(*args, **kwargs), None
    except (RecursionError, NotImplementedError):
        raise
    except REFERENCE_FAILURES as exc:
        return None, reason(exc)
