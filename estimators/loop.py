r"""The filter loop: one time loop for every problem, with one failure policy.

The library owns the loop; a problem supplies hooks (dynamax style):

``transition(e, belief) -> (model, u)``
    the model carrying the belief from epoch ``e - 1`` to ``e`` and its input;
``correct(e, belief) -> (belief, innovations)``
    everything the epoch's measurements do (zero or more updates, state augmentation,
    association); returns the innovations of its updates;
``record(e, belief)``
    stores what the caller wants of the epoch's posterior;
``check(e, belief)``
    optional; raises :class:`Divergence` to end the run (e.g. an error bound).

For ``e = 0`` only ``correct`` (when ``correct_first``) and ``record`` run; for
``e = 1 .. E - 1`` the loop predicts with ``steps.predict`` (the filter itself, or its
partitioned steps), corrects, checks the mean is finite, records and checks.

Failure policy
    Numerical failure never escapes the loop: a
    :class:`~estimators.linalg.NotPositiveDefiniteError` or any other
    ``LinAlgError``, a floating-point error (numpy raises on division by zero, overflow
    and invalid operations inside the loop), a non-finite mean or NIS, and a
    :class:`Divergence` raised by a hook end the run; :class:`LoopResult` then carries
    ``failure = "<ExceptionName>: <message>"`` and the last good belief.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators.linalg import Array
from estimators.models import Belief, Innovation, Transition

FAILURES: tuple[type[BaseException], ...] = (np.linalg.LinAlgError, ArithmeticError)
"""Exceptions that end a run as a divergence (``FloatingPointError`` and
:class:`Divergence` are ``ArithmeticError``\\ s)."""

_epoch_hook: Callable[[], None] | None = None


@dataclass(frozen=True)
class BeliefRecorder:
    """A ``record`` hook keeping every epoch's posterior: ``means`` (E, ambient) and
    ``covs`` (E, tangent, tangent), NaN at epochs not reached."""

    means: Array
    covs: Array

    @classmethod
    def empty(cls, epochs: int, ambient: int, tangent: int) -> BeliefRecorder:
        return cls(np.full((epochs, ambient), np.nan),
                   np.full((epochs, tangent, tangent), np.nan))

    def __call__(self, e: int, belief: Belief) -> None:
        self.means[e] = belief.mean
        self.covs[e] = belief.cov


def set_epoch_hook(hook: Callable[[], None] | None) -> None:
    """Call ``hook()`` after every epoch of every :func:`run_epochs` in this process
    (progress reporting only: it sees nothing and changes nothing); ``None`` removes it."""
    global _epoch_hook
    _epoch_hook = hook


def epoch_hook() -> Callable[[], None] | None:
    """The hook :func:`set_epoch_hook` installed (``None``: none)."""
    return _epoch_hook


class Divergence(ArithmeticError):
    """Raised by a problem's ``check`` hook: the run has left its bounds."""


@dataclass(frozen=True)
class LoopResult:
    """What the loop returns.

    belief : the last belief reached (the one before the failing step after a failure).
    epochs_done : the last epoch recorded.
    nis_epoch, nis, nis_dof : epoch, NIS and measurement dimension of every update.
    time_s : wall time of epochs ``1 .. E - 1`` (predict + correct cycles).
    failure : ``None``, or the reason the run ended early.
    """

    belief: Belief
    epochs_done: int
    nis_epoch: Array
    nis: Array
    nis_dof: Array
    time_s: float
    failure: str | None

    @property
    def diverged(self) -> bool:
        return self.failure is not None


class _Steps:
    """The filter's own predict (joint mode)."""

    def __init__(self, filt: Any):
        self.filt = filt

    def predict(self, b: Belief, model: Transition, u: Any) -> Belief:
        return self.filt.predict(b, model, u)


def _finite(e: int, b: Belief, innovations: Sequence[Innovation]) -> None:
    if not np.all(np.isfinite(b.mean)):
        raise FloatingPointError(f"non-finite state estimate at epoch {e}")
    for inn in innovations:
        if not np.isfinite(inn.nis):
            raise FloatingPointError(f"non-finite NIS at epoch {e}")


def run_epochs(filt: Any, belief: Belief, n_epochs: int, *,
               transition: Callable[[int, Belief], tuple[Transition, Any]],
               correct: Callable[[int, Belief], tuple[Belief, Sequence[Innovation]]],
               record: Callable[[int, Belief], None],
               check: Callable[[int, Belief], None] | None = None,
               steps: Any = None, correct_first: bool = False) -> LoopResult:
    """Run ``filt`` over ``n_epochs`` epochs (module docstring).

    ``steps`` provides ``predict(belief, model, u)`` (default: ``filt`` itself).
    """
    ops = _Steps(filt) if steps is None else steps
    nis_e: list[int] = []
    nis: list[float] = []
    dof: list[int] = []

    def corrected(e: int, b: Belief) -> Belief:
        b, inns = correct(e, b)
        _finite(e, b, inns)
        for inn in inns:
            nis_e.append(e)
            nis.append(inn.nis)
            dof.append(len(inn.nu))
        return b

    failure, done, elapsed = None, -1, 0.0
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
        try:
            if correct_first:
                belief = corrected(0, belief)
            record(0, belief)
            done = 0
            t0 = time.perf_counter()
            try:
                for e in range(1, n_epochs):
                    model, u = transition(e, belief)
                    b = corrected(e, ops.predict(belief, model, u))
                    belief = b
                    record(e, belief)
                    done = e
                    if _epoch_hook is not None:
                        _epoch_hook()
                    if check is not None:
                        check(e, belief)
            finally:
                elapsed = time.perf_counter() - t0
        except FAILURES as exc:
            failure = f"{type(exc).__name__}: {exc}"
    return LoopResult(belief, done, np.array(nis_e, dtype=int), np.array(nis, dtype=float),
                      np.array(dof, dtype=int), elapsed, failure)
