"""What a scenario kind is: the one value the registry (:mod:`slam.kinds`) holds per kind.

A kind is one folder under ``slam/kinds/`` holding everything that is only that kind's
(world schema, simulator and log, models, filter problem, GTSAM reference, scoring
specifics, report) and exporting one :class:`Kind`.  The command line, the campaign
runner, Dask, the atomic writer, the renderer and ``slam worlds`` only talk to the
registry, so adding a kind is one folder plus one registration.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from estimators.filters import FILTER_NAMES
from slam.render.document import KindReport
from slam.results import RunOutcome

Parser = Callable[[dict[str, Any], str, str, "Traversable | None"], Any]
"""``parse(data, name, source, base) -> world``: validate a TOML table into a world."""


class RunOnce(Protocol):
    """Simulate (or read) run ``run`` from its own seed and score every estimator."""

    def __call__(self, world: Any, run: int, seed_seq: np.random.SeedSequence,
                 filters: Sequence[str], keep_tracks: bool = False) -> RunOutcome: ...


class Summarize(Protocol):
    """The ``summary.json`` dict of a campaign from its runs' outcomes."""

    def __call__(self, world: Any, outcomes: list[RunOutcome], filters: list[str], runs: int,
                 seed: int) -> dict: ...


@dataclass(frozen=True)
class Kind:
    """One scenario kind.

    Attributes
    ----------
    name : the world files' ``kind`` value.
    parse : validates a world document of this kind (:data:`Parser`).
    run_once, summarize : one Monte Carlo run; the campaign summary.
    report : the report's sections, figures, terminal table and extra files.
    modes : the filter modes a world of this kind can run (``[filters] mode``,
        ``--mode``); empty when the kind has none.
    mode_filters : filters each non-default mode supports (mode -> names); a mode not
        listed supports every filter.
    open_log : for a kind that reads recorded logs, ``open_log(path, filters, mode)`` ->
        a world of this kind (``slam run --log FILE``); ``None`` otherwise.
    filters : every filter name a world of this kind can run (``--filters``, the world
        file's list); the standard Kalman-type filters unless the kind says more.
    """

    name: str
    parse: Parser
    run_once: RunOnce
    summarize: Summarize
    report: KindReport
    modes: tuple[str, ...] = ()
    mode_filters: dict[str, tuple[str, ...]] | None = None
    open_log: Callable[[Path, Sequence[str] | None, str | None], Any] | None = None
    filters: tuple[str, ...] = FILTER_NAMES
