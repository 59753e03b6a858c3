"""Guards against non-finite values entering a filter.

A NaN or infinite measurement, prior or model output would otherwise pass through the
linear algebra silently and surface one step later as a misleading "singular
innovation covariance".  The filters call :func:`require_finite` on what they receive
(prior, measurement) and on what their models return (transition and measurement
outputs, Jacobians), so the step that received the value raises
:class:`NonFiniteError` naming it.  ``NonFiniteError`` is a ``FloatingPointError``: the
filter loop (:mod:`estimators.loop`) counts it as a divergence.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class NonFiniteError(FloatingPointError):
    """A NaN or infinite value reached a filter (its message names which)."""


def require_finite(what: str, *arrays: Any) -> None:
    """Raise :class:`NonFiniteError` naming ``what`` unless every entry is finite."""
    for a in arrays:
        if a is not None and not np.isfinite(a).all():
            raise NonFiniteError(f"non-finite {what}")


def require_finite_input(u: Any) -> None:
    """:func:`require_finite` on a transition's input: an array, a tuple or list of
    arrays (e.g. gyro and accelerometer samples); anything not numeric is passed over."""
    if u is None:
        return
    if isinstance(u, tuple | list) and u and not np.isscalar(u[0]):
        for part in u:
            require_finite_input(part)
        return
    try:
        values = np.asarray(u, dtype=float)
    except (TypeError, ValueError):
        return
    require_finite("transition input", values)
