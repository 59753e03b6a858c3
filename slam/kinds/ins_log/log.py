"""Recorded IMU + GNSS logs: the log value, its epochs, and the two readers.

Readers (both raise :class:`~slam.kinds.recorded.log.LogFormatError`, ``file:line: message``)

``read_kitti(folder)``
    GTSAM's KITTI files (:data:`KITTI_FILES`): ``KittiEquivBiasedImu.txt`` (header, then
    ``time dt ax ay az wx wy wz``), ``KittiGps_converted.txt`` (header, then ``time,x,y,z``)
    and ``KittiEquivBiasedImu_metadata.txt`` (header, then the twelve calibration numbers);
    how the metadata is read is :data:`slam.kinds.ins_log.settings.KITTI_READING`.
``read_csv(path)``
    The CSV layout of :mod:`slam.kinds.ins_log` with its sidecar TOML
    (:mod:`slam.kinds.ins_log.sidecar`).

The log value holds readings in ENU/FLU SI units: reading ``k`` is the average rate and
specific force over ``(t[k-1], t[k]]`` (the first row's reading has no interval and is not
used).  :meth:`InsLog.epochs` cuts the readings at the fix times: a reading whose interval
straddles a fix is split into its two parts, so every epoch holds exactly the time between
its two fixes.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slam.kinds.recorded.log import LogFormatError

Array = NDArray[np.float64]
KITTI_FILES = ("KittiEquivBiasedImu.txt", "KittiGps_converted.txt",
               "KittiEquivBiasedImu_metadata.txt")
#: Largest file read (bytes) and most rows: bounds memory before parsing.
MAX_BYTES = 200_000_000
MAX_ROWS = 5_000_000
#: Readings further apart than this (s) are counted as gaps (they are still held).
GAP_S = 0.1
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?\Z")

__all__ = ["Epochs", "InsLog", "KITTI_FILES", "number", "read_lines"]


@dataclass(frozen=True)
class Epochs:
    """The readings cut at the fixes: pieces ``gyro, accel`` (N, 3) over ``dt`` (N,), and
    for epoch ``i`` (from fix ``i - 1`` to fix ``i``) the pieces ``start[i]:start[i + 1]``
    (``start`` has F + 1 entries; epoch 0 is empty)."""

    gyro: Array
    accel: Array
    dt: Array
    start: NDArray[np.int64]

    def of(self, i: int) -> tuple[Array, Array, Array]:
        s = slice(int(self.start[i]), int(self.start[i + 1]))
        return self.gyro[s], self.accel[s], self.dt[s]


@dataclass(frozen=True, eq=False)
class InsLog:
    """A recorded IMU + GNSS log in ENU / FLU SI units (module docstring).

    ``t`` (K,) reading stamps (s), ``gyro`` (K, 3) rad/s, ``accel`` (K, 3) m/s²;
    ``fix_t`` (F,), ``fix_p`` (F, 3) or None, ``fix_v`` (F, 3) or None, their σ
    ``fix_sp`` / ``fix_sv`` (F, 3); ``settings`` the log's stated (or default) settings
    (:class:`slam.kinds.ins_log.settings.LogSettings`); ``source`` where it was read;
    ``truth_p`` (F, 3) the true position at the fixes (NaN where not given) or None."""

    t: Array
    gyro: Array
    accel: Array
    fix_t: Array
    fix_p: Array | None
    fix_v: Array | None
    fix_sp: Array | None
    fix_sv: Array | None
    settings: Any
    source: str
    name: str
    dropped_fixes: int = 0
    notes: tuple[str, ...] = field(default=())
    truth_p: Array | None = None

    @property
    def n_fixes(self) -> int:
        return int(len(self.fix_t))

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def gaps(self) -> int:
        """Readings whose interval is longer than :data:`GAP_S`."""
        return int(np.sum(np.diff(self.t) > GAP_S))

    @cached_property
    def epochs(self) -> Epochs:
        """The pieces of every epoch (module docstring)."""
        edges = np.union1d(self.t, self.fix_t)
        edges = edges[(edges >= self.t[0]) & (edges <= self.t[-1])]
        ends = edges[1:]
        dt = np.diff(edges)
        reading = np.searchsorted(self.t, ends, side="left")  # first stamp >= the piece end
        epoch = np.searchsorted(self.fix_t, ends, side="left")  # fix_t[i-1] < end <= fix_t[i]
        keep = (epoch >= 1) & (epoch < self.n_fixes) & (dt > 0.0)
        reading, epoch, dt = reading[keep], epoch[keep], dt[keep]
        start = np.searchsorted(epoch, np.arange(self.n_fixes + 1), side="left")
        start[0] = 0
        return Epochs(self.gyro[reading], self.accel[reading], dt, start.astype(np.int64))


def number(text: str, source: str, line: int, what: str) -> float:
    """A finite decimal number (ASCII digits, optional exponent), else the file's error."""
    tok = text.strip()
    if len(tok) > 64 or not _NUMBER.match(tok):
        shown = tok if len(tok) <= 24 else tok[:21] + "..."
        raise LogFormatError(source, line, f"{what} = {shown!r}: not a decimal number")
    value = float(tok)
    if not math.isfinite(value) or (value != 0.0 and abs(value) < 1e-300):
        raise LogFormatError(source, line, f"{what} = {tok}: out of range (a finite number "
                             "of magnitude 1e-300 to 1e300, or 0)")
    return value


def read_lines(path: Path) -> list[str]:
    """The file's lines (UTF-8), with the size checked first."""
    source = str(path)
    try:
        size = path.stat().st_size
        if not path.is_file():
            raise LogFormatError(source, None, "not a regular file")
        if size > MAX_BYTES:
            raise LogFormatError(source, None, f"{size} bytes: larger than {MAX_BYTES}")
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise LogFormatError(source, None, f"not UTF-8 text (byte {exc.start})") from None
    except OSError as exc:
        raise LogFormatError(source, None, f"cannot be read ({exc.strerror or exc})") from None
    lines = text.splitlines()
    if len(lines) > MAX_ROWS:
        raise LogFormatError(source, None, f"{len(lines)} lines: more than {MAX_ROWS}")
    return lines


def check_times(t: Array, source: str, lines: list[int], what: str) -> None:
    """Strictly increasing stamps, else the first offending line."""
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if len(bad):
        k = int(bad[0]) + 1
        raise LogFormatError(source, lines[k], f"{what} time {t[k]!r} does not increase "
                             f"(previous {t[k - 1]!r})")


def in_range_fixes(t: Array, fix_t: Array) -> NDArray[np.bool_]:
    """Fixes inside the readings' span (the others have no IMU data around them)."""
    return (fix_t >= t[0]) & (fix_t <= t[-1])
