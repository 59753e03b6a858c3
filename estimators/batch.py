r"""Monte Carlo runs as an array axis: the filter loop over a batch of runs.

Every filter step accepts a *batch* of beliefs - ``mean`` (B, n), ``cov`` (B, d, d) or
``sqrt`` (B, d, d) - and returns, for each member, what the per-run call returns (to
round-off; ``tests/estimators/test_batch.py``).  :func:`run_batch` is
:func:`estimators.loop.run_epochs` for such a batch: the runs go through the same epochs
together, so numpy's per-call overhead is paid once per epoch for all of them.

Hooks see the batch and the indices of its members among the runs it started with:

``transition(e, belief, live) -> (model, u)``, ``correct(e, belief, live) ->
(belief, innovations)``, ``record(e, belief, live)``, ``check(e, belief, live)``

(``live`` an int array; the models' functions take points (B, m, n) and inputs with the
same leading axis).

Failure policy (the per-run loop's, run by run)
    When any step of an epoch raises one of :data:`~estimators.loop.FAILURES` (a
    ``LinAlgError``, a floating-point error, a non-finite value, a :class:`Divergence`,
    a bad noise) for the batch, that epoch is re-run member by member (each as a batch of
    one, from the belief before the epoch).  A member that fails alone ends with the
    reason its per-run loop gives and the belief before that epoch; the others go on as
    one batch.  So a failing run never takes the others with it, and every run's result
    is the per-run loop's.  ``record`` may be called twice for an epoch (the batch
    attempt, then the member's own): it must overwrite, not append.

Time: each epoch's wall time is shared equally among the members that ran it; a run's
``time_s`` is its share (the per-run cost of a batched campaign).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from estimators.linalg import Array
from estimators.loop import FAILURES, LoopResult, _Steps, epoch_hook
from estimators.models import Belief, Gaussian, Innovation, SqrtGaussian, Transition

__all__ = ["BatchRuns", "advance", "member", "run_batch", "stack", "take"]


def take(belief: Belief, index: Array | Sequence[int]) -> Belief:
    """The members ``index`` of a batch of beliefs (a batch again)."""
    idx = np.asarray(index, dtype=int)
    if isinstance(belief, SqrtGaussian):
        return SqrtGaussian(belief.mean[idx], belief.sqrt[idx], belief.space)
    return Gaussian(belief.mean[idx], belief.cov[idx], belief.space)


def member(belief: Belief, j: int) -> Belief:
    """Member ``j`` of a batch as a single (unbatched) belief."""
    if isinstance(belief, SqrtGaussian):
        return SqrtGaussian(belief.mean[j], belief.sqrt[j], belief.space)
    return Gaussian(belief.mean[j], belief.cov[j], belief.space)


def stack(beliefs: Sequence[Belief]) -> Belief:
    """One batch of same-space beliefs (each a batch or a single belief)."""
    first = beliefs[0]

    def cat(arrays: list[Array], single_ndim: int) -> Array:
        return np.concatenate([a if a.ndim > single_ndim else a[None] for a in arrays])

    mean = cat([b.mean for b in beliefs], 1)
    if isinstance(first, SqrtGaussian):
        return SqrtGaussian(mean, cat([b.sqrt for b in beliefs], 2), first.space)
    return Gaussian(mean, cat([b.cov for b in beliefs], 2), first.space)


class BatchRuns:
    """Per-run bookkeeping of batched loops (:func:`advance`): NIS, time, the last epoch
    recorded, the failure and the belief a failed run ended with."""

    def __init__(self, n: int):
        self.nis: list[list[tuple[int, float, int]]] = [[] for _ in range(n)]
        self.time = np.zeros(n)
        self.done = np.full(n, -1)
        self.failure: list[str | None] = [None] * n
        self.last: list[Belief | None] = [None] * n
        self.after: Belief | None = None

    def innovations(self, e: int, live: Array, inns: Sequence[Innovation]) -> None:
        for inn in inns:
            nis = np.atleast_1d(inn.nis)
            dof = inn.nu.shape[-1]
            for j, r in enumerate(live):
                self.nis[r].append((e, float(nis[j]), dof))

    def epoch(self, ops: Any, hooks: Hooks, e: int, b: Belief, live: Array,
              correct_first: bool = False) -> Belief:
        """One epoch of the loop for the batch ``b`` (members ``live``): predict, correct,
        the finiteness check, record, check (the order of
        :func:`~estimators.loop.run_epochs`); raises on a failure."""
        transition, correct, record, check = hooks
        if e > 0:
            model, u = transition(e, b, live)
            b = ops.predict(b, model, u)
        inns: Sequence[Innovation] = []
        if e > 0 or correct_first:
            b, inns = correct(e, b, live)
            _finite(e, b, inns)
        self.innovations(e, live, inns)
        record(e, b, live)
        self.done[live] = e
        self.after = b  # a failing check leaves this (recorded) belief, as run_epochs does
        if e > 0 and check is not None:
            check(e, b, live)
        return b

    def results(self, finals: dict[int, Belief]) -> list[LoopResult]:
        """One :class:`~estimators.loop.LoopResult` per run; ``finals`` holds the final
        belief of every run that did not fail."""
        out = []
        for r in range(len(self.nis)):
            nis = self.nis[r]
            last = self.last[r]
            out.append(LoopResult(
                last if last is not None else finals[r], int(self.done[r]),
                np.array([x[0] for x in nis], dtype=int),
                np.array([x[1] for x in nis], dtype=float),
                np.array([x[2] for x in nis], dtype=int), float(self.time[r]),
                self.failure[r]))
        return out


Hooks = tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any],
              Callable[..., Any] | None]
"""``(transition, correct, record, check)`` of a batched loop (module docstring)."""


def _finite(e: int, b: Belief, innovations: Sequence[Innovation]) -> None:
    if not np.all(np.isfinite(b.mean)):
        raise FloatingPointError(f"non-finite state estimate at epoch {e}")
    for inn in innovations:
        if not np.all(np.isfinite(inn.nis)):
            raise FloatingPointError(f"non-finite NIS at epoch {e}")


def advance(runs: BatchRuns, step: Callable[[int, Belief, Array], Belief], e: int,
            belief: Belief, live: Array) -> tuple[Belief, Array]:
    """Epoch ``e`` of the batch ``belief`` (members ``live``) by ``step(e, belief, live)``
    with the failure policy (module docstring): on a failure the epoch is re-run member by
    member and the members that fail alone end there.  Returns the batch after the epoch
    and its surviving members; the epoch's time is shared among them."""
    t0 = time.perf_counter()
    saved = [len(runs.nis[r]) for r in live]  # an epoch only appends to them
    try:
        belief = step(e, belief, live)
    except FAILURES:
        for i, r in enumerate(live):  # undo the batch attempt's innovations
            del runs.nis[r][saved[i]:]
        belief, live = _one_by_one(step, e, belief, live, runs)
    if e > 0 and live.size:
        runs.time[live] += (time.perf_counter() - t0) / live.size
        hook = epoch_hook()
        if hook is not None:
            for _ in live:
                hook()
    return belief, live


def run_batch(filt: Any, belief: Belief, n_epochs: int, *,
              transition: Callable[[int, Belief, Array], tuple[Transition, Any]],
              correct: Callable[[int, Belief, Array], tuple[Belief, Sequence[Innovation]]],
              record: Callable[[int, Belief, Array], None],
              check: Callable[[int, Belief, Array], None] | None = None,
              steps: Any = None, correct_first: bool = False) -> list[LoopResult]:
    """Run a batch of beliefs (leading axis: the runs) over ``n_epochs`` epochs (module
    docstring); one :class:`~estimators.loop.LoopResult` per run, in order, each what
    :func:`~estimators.loop.run_epochs` gives for that run alone."""
    ops = _Steps(filt) if steps is None else steps
    n = belief.mean.shape[0]
    runs = BatchRuns(n)
    hooks = (transition, correct, record, check)

    def step(e: int, b: Belief, live: Array) -> Belief:
        return runs.epoch(ops, hooks, e, b, live, correct_first)

    live = np.arange(n)
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
        for e in range(n_epochs):
            if not live.size:
                break
            belief, live = advance(runs, step, e, belief, live)
    return runs.results({int(r): member(belief, j) for j, r in enumerate(live)})


def _one_by_one(epoch: Callable[[int, Belief, Array], Belief], e: int, belief: Belief,
                live: Array, runs: BatchRuns) -> tuple[Belief, Array]:
    """Re-run epoch ``e`` for each member alone; the members that fail end there."""
    kept: list[Belief] = []
    alive: list[int] = []
    for j, r in enumerate(live):
        bj = take(belief, [j])
        runs.done[r] = e - 1
        runs.after = None
        try:
            kept.append(epoch(e, bj, np.array([r])))
            alive.append(int(r))
        except FAILURES as exc:
            runs.failure[r] = f"{type(exc).__name__}: {exc}"
            runs.last[r] = member(belief, j) if runs.after is None else member(runs.after, 0)
    if not kept:
        return belief, np.zeros(0, dtype=int)
    return stack(kept), np.array(alive, dtype=int)
