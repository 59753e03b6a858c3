"""A recorded attitude log in the role of a world (:class:`AttitudeLogWorld`), opened by
:func:`open_log` for ``slam run --log eqf`` (or a path): the log, the filters and their
stated settings, the initial belief, without the modules that run them."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam.kinds.attitude_log.log import AttitudeRecord, read_attitude_log
from slam.kinds.recorded.world import LOG_SETTINGS
from worlds import limits
from worlds.common import TunedFilters

KIND = "recorded-attitude"
DEFAULT_FILTERS: tuple[str, ...] = ("ekf", "srckf", "srukf")
ATTITUDE_LOG_FILTERS: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf",
                                         "srcdkf")
INITIAL_ATTITUDE_VAR_RAD2 = 0.1
INITIAL_BIAS_VAR_RAD2_S2 = 0.01
"""The initial belief of every estimator (GTSAM's ABC EqF example): identity attitude and
zero bias, P0 = diag(0.1 I3 rad², 0.01 I3 rad²/s²); the log has no world file to state it,
the report prints it."""


@dataclass(frozen=True)
class AttitudeLogFilters(TunedFilters):
    """The filters run on the log and their settings (:data:`LOG_SETTINGS` of the planar
    recorded logs: Julier's unscented set, central-difference step √3)."""

    names: tuple[str, ...]
    initial_attitude_var_rad2: float = INITIAL_ATTITUDE_VAR_RAD2
    initial_bias_var_rad2_s2: float = INITIAL_BIAS_VAR_RAD2_S2

    @property
    def mode(self) -> None:
        return None

    def initial(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x0, P0)``: ``[q = 1, b = 0]`` and the diagonal prior."""
        x0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        return x0, np.diag([self.initial_attitude_var_rad2] * 3
                           + [self.initial_bias_var_rad2_s2] * 3)


@dataclass(frozen=True, eq=False)
class AttitudeLogWorld:
    """A recorded attitude log: one run, scored against its truth and the smoother."""

    name: str
    source: str
    log: AttitudeRecord
    filters: AttitudeLogFilters
    kind: str = KIND
    runs: int = 1
    seed: int = 0
    description: str = ("recorded gyro + direction-sensor log (GTSAM EqFdata.csv layout), "
                        "scored against its truth and the GTSAM AHRS smoother")


def open_log(path: Path, filters: Sequence[str] | None = None, mode: str | None = None
             ) -> AttitudeLogWorld:
    """Read ``path`` (raises :class:`~slam.kinds.recorded.log.LogFormatError`)."""
    log = read_attitude_log(path)
    return AttitudeLogWorld(Path(path).stem, str(path), log,
                            AttitudeLogFilters(tuple(filters or DEFAULT_FILTERS),
                                               **LOG_SETTINGS))


def work(w: AttitudeLogWorld) -> Iterator[limits.Size]:
    """Rows, filter epochs, the 6-state filter with up to 3·S measurements and its work
    (:func:`worlds.limits.filter_work`)."""
    log = w.log
    epochs = len(log.epochs)
    yield limits.Size("samples", "gyro samples", log.n_rows, None)
    yield limits.Size("epochs", "filter epochs", epochs, None)
    yield limits.Size("state", "state dimensions", 6, None)
    yield limits.Size("work", "units of filter work",
                      limits.filter_work(epochs, log.n_rows, 6, 6), None)
