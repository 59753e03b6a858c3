"""A recorded log in the role of a world (:class:`RecordedWorld`), opened by
:func:`open_log` for ``slam run --log FILE``: the log's records and the filters to run on
it, without the modules that run them (the command line reads a log before it loads
them)."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from estimators.rules import JULIER_KAPPA
from slam.kinds.recorded.log import (
    DEFAULT_FILTERS,
    DEFAULT_MAX_EPOCH_STEPS,
    LogFormatError,
    OdometryLog,
    read_odometry_log,
)
from worlds import limits
from worlds.common import TunedFilters

KIND = "recorded-log"
MODES = ("local", "joint")


LOG_SETTINGS = {"unscented": {"alpha": 1.0, "beta": 0.0, "kappa": JULIER_KAPPA},
                "central_difference": {"h": math.sqrt(3.0)},
                "iterated": {"iterations": 5, "tolerance": 1e-9}}
"""The settings of the filters run on a recorded log (there is no world file to state
them; the report prints them): Julier's original unscented set (alpha = 1, beta = 2,
kappa = 0 would be the cubature point set), the central-difference step sqrt(3), and for
the iterated updates at most 5 iterations down to a whitened step of 1e-9."""


@dataclass(frozen=True)
class RecordedFilters(TunedFilters):
    """The filters run on the log, their mode and settings (:data:`LOG_SETTINGS`);
    ``online`` adds the online row ``isam2`` (``--online``,
    :mod:`slam.kinds.recorded.online`)."""

    names: tuple[str, ...]
    mode: str
    online: bool = False


@dataclass(frozen=True, eq=False)
class RecordedWorld:
    """A recorded log in the role of a world: one run, no truth (scored against the
    smoother)."""

    name: str
    source: str
    log: OdometryLog
    filters: RecordedFilters
    kind: str = KIND
    runs: int = 1
    seed: int = 0
    description: str = "recorded planar SLAM log (GTSAM text format), scored against the smoother"


def open_log(path: Path, filters: Sequence[str] | None = None, mode: str | None = None
             ) -> RecordedWorld:
    """Read ``path`` (raises :class:`~slam.kinds.recorded.log.LogFormatError`); a log of a
    single pose (no odometry) has nothing to filter and is refused."""
    log = read_odometry_log(path)
    if log.n_poses < 2:
        raise LogFormatError(str(path), None, "holds a single pose (no ODOMETRY record): "
                             "nothing to filter or smooth")
    return RecordedWorld(Path(path).stem, str(path), log,
                         RecordedFilters(tuple(filters or DEFAULT_FILTERS), mode or MODES[0],
                                         **LOG_SETTINGS))


def work(w: RecordedWorld) -> Iterator[limits.Size]:
    """What the run on a log costs (:mod:`worlds.limits`; sizes of the file as a whole):
    poses, sightings, filter epochs (every pose with sightings, the last, and one every
    :data:`~slam.kinds.recorded.log.DEFAULT_MAX_EPOCH_STEPS` odometry steps between), the
    state with every landmark mapped, the measurements of one update, the filter work -
    ``Σ (state + 3 steps)³`` over the epochs in joint mode, ``Σ (3 + 3 steps)³ +
    10 state²`` in local mode (the planar kind's measure)."""
    log = w.log
    yield limits.Size("samples", "poses", log.n_poses, None)
    yield limits.Size("samples", "sightings", len(log.obs_id), None)
    events = np.unique(np.concatenate([[0, log.n_poses - 1], log.obs_pose]))
    gaps = np.diff(events)
    splits = np.maximum(-(-gaps // DEFAULT_MAX_EPOCH_STEPS), 1)  # epochs per gap
    epochs = 1 + int(splits.sum())
    yield limits.Size("epochs", "filter epochs", epochs, None)
    landmarks = len(log.landmark_ids)
    state = 3 + 2 * landmarks
    yield limits.Size("state", "state dimensions", state, None, f"{landmarks} landmarks")
    at_once = int(np.bincount(log.obs_pose).max()) if len(log.obs_pose) else 0
    yield limits.Size("state", "measurements in one update", 2 * at_once, None,
                      f"{at_once} sightings from one pose")
    width = 3.0 * np.repeat(gaps / splits, splits)  # the noise inputs of each prediction
    joint = w.filters.mode == "joint"
    cost = float(np.sum((state + width) ** 3) if joint
                 else np.sum((3 + width) ** 3 + 10.0 * state**2))
    yield limits.Size("work", "units of filter work", cost, None,
                      f"{epochs} epochs, state {state}, {w.filters.mode} mode")
