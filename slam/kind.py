"""What a scenario kind is: the one value the registry (:mod:`slam.kinds`) holds per kind.

A kind is one folder under ``slam/kinds/`` holding everything that is only that kind's
(world schema, simulator and log, models, filter problem, GTSAM reference, scoring
specifics, report) and exporting one :class:`Kind`.  The command line, the campaign
runner, Dask, the atomic writer, the renderer and ``slam worlds`` only talk to the
registry, so adding a kind is one folder plus one registration.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, fields
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from estimators.filters import FILTER_NAMES
from slam.render.document import KindReport
from slam.results import RunOutcome
from worlds.limits import Size

Parser = Callable[[dict[str, Any], str, str, "Traversable | None"], Any]
"""``parse(data, name, source, base) -> world``: validate a TOML table into a world."""

WorkOf = Callable[[Any], Iterable[Size]]
"""``work(world) -> sizes``: what one run of a validated world costs - its samples, filter
epochs, state dimension and filter work (:class:`worlds.limits.Size`, each naming the
key that drives it), in the order they are cheap to compute."""


class RunOnce(Protocol):
    """Simulate (or read) run ``run`` from its own seed and score every estimator."""

    def __call__(self, world: Any, run: int, seed_seq: np.random.SeedSequence,
                 filters: Sequence[str], keep_tracks: bool = False) -> RunOutcome: ...


class RunBatch(Protocol):
    """Simulate (or read) runs ``runs`` from their own seeds and score every estimator on
    each, the filters over all the runs at once where they can (the runs as an array
    axis); each outcome equals :class:`RunOnce`'s for that run."""

    def __call__(self, world: Any, runs: Sequence[int],
                 seed_seqs: Sequence[np.random.SeedSequence], filters: Sequence[str],
                 keep_first: bool = False) -> list[RunOutcome]: ...


class Summarize(Protocol):
    """The ``summary.json`` dict of a campaign from its runs' outcomes."""

    def __call__(self, world: Any, outcomes: list[RunOutcome], filters: list[str], runs: int,
                 seed: int) -> dict: ...


@dataclass(frozen=True)
class Deferred:
    """``"package.module:attribute"``, imported when first used.

    A kind's run, summary and report modules pull in SciPy and GTSAM (about a second of
    start-up), which a command that only validates or lists worlds never needs; the kind
    names them with a :class:`Deferred` instead of importing them.  A kind's report names
    its figure module the same way, so a run without figures never imports matplotlib.
    Calling it calls the attribute, reading an attribute of it reads the attribute's
    (so ``kind.report.text_table(...)`` works either way); :meth:`Kind.load` imports every
    deferred part at once.
    """

    target: str

    def load(self) -> Any:
        """The attribute, imported (``ImportError`` / ``AttributeError`` if it is not there)."""
        module, _, attribute = self.target.partition(":")
        return getattr(importlib.import_module(module), attribute)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.load()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "target":  # copy/pickle probes; no recursion
            raise AttributeError(name)
        return getattr(self.load(), name)


@dataclass(frozen=True)
class Kind:
    """One scenario kind.

    Attributes
    ----------
    name : the world files' ``kind`` value.
    parse : validates a world document of this kind (:data:`Parser`).
    run_once, summarize : one Monte Carlo run; the campaign summary.
    report : the report's sections, figures, terminal table and extra files.
        ``run_once``, ``summarize``, ``report`` and ``open_log`` may be :class:`Deferred`.
    modes : the filter modes a world of this kind can run (``[filters] mode``,
        ``--mode``); empty when the kind has none.
    mode_filters : filters each non-default mode supports (mode -> names); a mode not
        listed supports every filter.
    open_log : for a kind that reads recorded logs, ``open_log(path, filters, mode)`` ->
        a world of this kind (``slam run --log FILE``); ``None`` otherwise.
    filters : every filter name a world of this kind can run (``--filters``, the world
        file's list); the standard Kalman-type filters unless the kind says more.
    run_batch : the batched path (:class:`RunBatch`), or ``None`` when the kind only has
        the per-run one; the campaign uses it unless asked for the per-run path.
    work : what one run of a world of this kind costs (:data:`WorkOf`; required,
        keyword-only): the registry checks it against :mod:`worlds.limits` before a
        world is used.
    """

    name: str
    parse: Parser
    run_once: RunOnce | Deferred
    summarize: Summarize | Deferred
    report: KindReport | Deferred
    modes: tuple[str, ...] = ()
    mode_filters: dict[str, tuple[str, ...]] | None = None
    open_log: Callable[[Path, Sequence[str] | None, str | None], Any] | Deferred | None = None
    filters: tuple[str, ...] = FILTER_NAMES
    run_batch: RunBatch | Deferred | None = None
    work: WorkOf = field(kw_only=True)

    def load(self) -> None:
        """Import every :class:`Deferred` part now (the command line does it with Ctrl-C
        held back, before a campaign starts)."""
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, Deferred):
                value.load()
