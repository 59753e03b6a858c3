"""A recorded IMU + GNSS log in the role of a world (:class:`InsLogWorld`), opened by
:func:`open_log` for ``slam run --log kitti|FILE.csv [--holdout K] [--outage S:L]``."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from slam.kinds.ins_log.log import KITTI_FILES, InsLog
from slam.kinds.ins_log.settings import LogFilters
from slam.kinds.recorded.log import LogFormatError
from worlds import limits

KIND = "ins-log"
#: Held-out fixes are scored from this fix on (the alignment transient before it).
SCORE_FROM = 60


@dataclass(frozen=True)
class Scoring:
    """How a log without truth is scored: every ``holdout``-th fix withheld (``None``:
    none) and scored from fix :data:`SCORE_FROM`; GNSS outages ``(start_s, length_s)``
    from the first IMU stamp, all fixes inside dropped, the drift scored at the last."""

    holdout: int | None = None
    outages: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True, eq=False)
class InsLogWorld:
    """A recorded IMU + GNSS log in the role of a world: one run, no truth."""

    name: str
    source: str
    log: InsLog
    filters: LogFilters
    scoring: Scoring
    kind: str = KIND
    runs: int = 1
    seed: int = 0
    description: str = ("recorded IMU + GNSS log; INS filters and the GTSAM IMU + GPS "
                        "smoother scored at held-out fixes and GNSS outages")


def reads(path: Path | str) -> bool:
    """Whether ``--log path`` is an IMU + GNSS log (``kitti``, a ``.csv``, or a folder of
    the KITTI files)."""
    p = Path(path)
    return str(path) == "kitti" or p.suffix.lower() == ".csv" or (p / KITTI_FILES[0]).exists()


def parse_outage(text: str) -> tuple[float, float]:
    """``START:LENGTH`` (seconds) -> ``(start, length)``; ``ValueError`` naming the rule."""
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start, length = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"--outage {text!r}: START:LENGTH in seconds, e.g. 200:30") from None
    if not (math.isfinite(start) and math.isfinite(length) and 0.0 <= start <= 1e6
            and 0.0 < length <= 1e6):
        raise ValueError(f"--outage {text!r}: START in [0, 1e6] s, LENGTH in (0, 1e6] s")
    return start, length


def open_log(path: Path, filters: Sequence[str] | None = None, mode: str | None = None,
             holdout: int | None = None, outages: Sequence[tuple[float, float]] = ()
             ) -> InsLogWorld:
    """Read the log (raises :class:`~slam.kinds.recorded.log.LogFormatError`)."""
    from slam.kinds.ins_log.readers import bundled_kitti, read_csv, read_kitti

    names = tuple(filters) if filters else None
    if str(path) == "kitti":
        log = read_kitti(bundled_kitti(), names)
    elif Path(path).suffix.lower() == ".csv":
        log = read_csv(Path(path), names)
    else:
        log = read_kitti(Path(path), names)
    if mode is not None:
        raise LogFormatError(log.source, None, "--mode does not apply to an IMU + GNSS log")
    if holdout is not None and not 2 <= holdout <= 1000:
        raise LogFormatError(log.source, None, f"--holdout {holdout}: must be in [2, 1000]")
    for start, length in outages:
        if start >= log.duration_s:
            raise LogFormatError(log.source, None, f"--outage {start:g}:{length:g}: starts "
                                 f"after the log's end ({log.duration_s:.1f} s)")
    return InsLogWorld(log.name, log.source, log, log.settings.filters,
                       Scoring(holdout, tuple(outages)))


def work(w: InsLogWorld) -> Iterator[limits.Size]:
    """What the run costs: IMU pieces, epochs (fixes), the 15-d state and the filter work
    (``Σ pieces · 31 points`` mechanised plus ``15³`` per epoch)."""
    log = w.log
    pieces = len(log.t) + log.n_fixes
    yield limits.Size("samples", "IMU readings", len(log.t), None)
    yield limits.Size("epochs", "GNSS epochs", log.n_fixes, None)
    yield limits.Size("state", "state dimensions", 15, None)
    yield limits.Size("work", "units of filter work", 31.0 * pieces * 50 + log.n_fixes * 15**3,
                      None, f"{pieces} IMU pieces, {log.n_fixes} epochs")
