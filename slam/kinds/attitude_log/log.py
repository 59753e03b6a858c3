r"""Recorded attitude logs in GTSAM's ``EqFdata.csv`` layout: reading and validation.

A comma-separated file with one header line naming the columns (any order) and one row
per gyro sample::

    t                        time (s), strictly increasing
    q_w q_x q_y q_z          true attitude q_nb (unit quaternion)
    b_x b_y b_z              true gyro bias (rad/s)
    w_x w_y w_z              gyro reading (rad/s); row k's reading covers (t_{k-1}, t_k]
    std_w_x std_w_y std_w_z  gyro angle random walk density (rad/√s), one value per log
    std_b_x std_b_y std_b_z  bias random walk density (rad/s/√s), one value per log
    y_x_i y_y_i y_z_i        direction sensor i's unit reading in its own frame (NaN: none)
    std_y_x_i ...            its standard deviation per axis
    d_x_i d_y_i d_z_i        the unit navigation-frame direction it reads (NaN: none)
    cq_w_i ... cq_z_i        optional: the sensor's mounting rotation (identity if absent)

Sensor ``i`` (0, 1, ...) reads :math:`y_i = C(cq_i)^\top C(q)^\top d_i + v`; the mounting is
taken as known, so the body-frame reading is :math:`C(cq_i)\,y_i`.  A sensor counts at
a row when its reading and its direction are both given.  ``NaN`` is allowed only in the
``y`` and ``d`` columns; every other value must be a finite number.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from nav.observations import UNIT_TOL
from nav.quaternion import qrotate
from slam.kinds.recorded.log import LogFormatError
from worlds import limits

Array = NDArray[np.float64]
XYZ, WXYZ = ("x", "y", "z"), ("w", "x", "y", "z")
REQUIRED = ("t", *(f"{p}_{a}" for p in ("q",) for a in WXYZ),
            *(f"{p}_{a}" for p in ("b", "w", "std_w", "std_b") for a in XYZ))
SENSOR = re.compile(r"^y_x_(\d{1,3})$")
NORM_TOL = 1e-6  # |‖q‖ - 1| allowed for the truth and mounting quaternions
MAX_SENSORS = 16
MAX_GAP_S = 10.0  # the longest interval between two rows
TINY = float(np.finfo(float).tiny)  # a σ whose square is below this underflows


@dataclass(frozen=True, eq=False)
class AttitudeRecord:
    """A recorded attitude log (arrays of N rows, S direction sensors).

    t (N,); truth_q (N, 4) q_nb; truth_bias (N, 3) rad/s; gyro (N, 3) rad/s (row k covers
    (t_{k-1}, t_k]); arw (3,) rad/√s; bias_rw (3,) rad/s/√s; body (N, S, 3) body-frame
    unit readings; refs (N, S, 3) navigation-frame directions; sigma (N, S, 3) per-axis
    σ; seen (N, S) where sensor s reads; source: the file.
    """

    t: Array
    truth_q: Array
    truth_bias: Array
    gyro: Array
    arw: Array
    bias_rw: Array
    body: Array
    refs: Array
    sigma: Array
    seen: NDArray[np.bool_]
    source: str

    @property
    def n_rows(self) -> int:
        return len(self.t)

    @property
    def n_sensors(self) -> int:
        return self.seen.shape[1]

    @property
    def epochs(self) -> NDArray[np.int64]:
        """The filter epochs: the first row, every row with a reading, the last row."""
        return np.union1d(np.flatnonzero(self.seen.any(axis=1)), [0, self.n_rows - 1])


def _fail(src: str, line: int | None, message: str) -> LogFormatError:
    return LogFormatError(src, line, message)


def _header(first: str, src: str) -> tuple[list[str], list[int]]:
    names = [c.strip() for c in first.split(",")]
    seen: set[str] = set()
    for c in names:
        if c in seen:
            raise _fail(src, 1, f"column {c!r} appears twice")
        seen.add(c)
    missing = [c for c in REQUIRED if c not in seen]
    if missing:
        raise _fail(src, 1, f"missing column(s) {', '.join(missing[:6])}; an EqFdata.csv "
                    f"header names {', '.join(REQUIRED[:5])}, ...")
    sensors = sorted({int(m[1]) for c in names if (m := SENSOR.match(c))})
    if not sensors:
        raise _fail(src, 1, "no direction sensor (columns y_x_0, y_y_0, y_z_0, std_y_*_0, "
                    "d_*_0)")
    if sensors != list(range(len(sensors))) or len(sensors) > MAX_SENSORS:
        raise _fail(src, 1, f"direction sensors {sensors[:8]}: must be numbered 0, 1, ... "
                    f"(at most {MAX_SENSORS})")
    for i in sensors:
        need = [f"{p}_{a}_{i}" for p in ("y", "std_y", "d") for a in XYZ]
        gap = [c for c in need if c not in seen]
        if gap:
            raise _fail(src, 1, f"sensor {i}: missing column(s) {', '.join(gap)}")
        cq = [f"cq_{a}_{i}" for a in WXYZ]
        if any(c in seen for c in cq) and not all(c in seen for c in cq):
            raise _fail(src, 1, f"sensor {i}: give all of {', '.join(cq)} or none")
    return names, sensors


def _rows(lines: list[str], width: int, src: str) -> Array:
    out = np.empty((len(lines), width))
    for k, line in enumerate(lines):
        tokens = line.split(",")
        if len(tokens) != width:
            raise _fail(src, k + 2, f"{len(tokens)} fields; the header names {width}")
        for j, tok in enumerate(tokens):
            try:
                out[k, j] = float(tok)
            except ValueError:
                shown = tok.strip()[:40]
                raise _fail(src, k + 2, f"field {j + 1}: {shown!r} is not a number") from None
    return out


def _unit(v: Array, tol: float) -> NDArray[np.bool_]:
    return np.abs(np.linalg.norm(v, axis=-1) - 1.0) <= tol


def _first_bad(mask: NDArray[np.bool_]) -> int:
    return int(np.flatnonzero(mask)[0]) + 2


def parse_attitude_log(text: str, src: str) -> AttitudeRecord:
    """Parse the CSV text (module docstring); raises :class:`LogFormatError` naming the
    file, the line and the rule."""
    with np.errstate(over="ignore", invalid="ignore"):  # huge values are refused, not warned
        return _parse(text, src)


def _parse(text: str, src: str) -> AttitudeRecord:
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise _fail(src, None, "empty file")
    names, sensors = _header(lines[0], src)
    body_lines = lines[1:]
    if len(body_lines) < 2:
        raise _fail(src, None, "needs at least 2 rows after the header")
    if len(body_lines) > limits.limit_of("samples"):
        raise _fail(src, None, f"{len(body_lines):,} rows; at most "
                    f"{limits.limit_of('samples'):,} are allowed")
    A = _rows(body_lines, len(names), src)
    col = {c: j for j, c in enumerate(names)}

    def take(*cols: str) -> Array:
        return A[:, [col[c] for c in cols]]

    base = take(*REQUIRED)
    bad = ~np.isfinite(base)
    if bad.any():
        k, j = np.argwhere(bad)[0]
        raise _fail(src, int(k) + 2, f"{REQUIRED[j]} = {base[k, j]}: must be a finite number")
    t = base[:, 0]
    dt = np.diff(t)
    if not np.all(dt > 0):
        k = _first_bad(~(dt > 0)) + 1
        raise _fail(src, k, "t must be strictly increasing")
    if np.any(dt > MAX_GAP_S):
        raise _fail(src, _first_bad(dt > MAX_GAP_S) + 1,
                    f"a gap of more than {MAX_GAP_S:g} s between rows")
    q = base[:, 1:5]
    if not np.all(_unit(q, NORM_TOL)):
        raise _fail(src, _first_bad(~_unit(q, NORM_TOL)),
                    f"q_w..q_z: not a unit quaternion (|‖q‖ - 1| > {NORM_TOL:g})")
    noise = base[:, 11:17]
    small = (noise <= 0) | (noise**2 < TINY)
    if np.any(small):
        raise _fail(src, _first_bad(np.any(small, axis=1)),
                    "std_w_* and std_b_* must be > 0 (and their squares must not underflow)")
    if np.any(noise != noise[0]):
        raise _fail(src, _first_bad(np.any(noise != noise[0], axis=1)),
                    "std_w_* and std_b_* must be the same on every row (one gyro)")
    if np.any(noise[0] > 1.0):
        raise _fail(src, 2, "std_w_* and std_b_* must be at most 1 (rad/√s, rad/s/√s)")
    N, S = len(t), len(sensors)
    body, refs, sigma = (np.full((N, S, 3), np.nan) for _ in range(3))
    seen = np.zeros((N, S), dtype=bool)
    for i in sensors:
        y = take(*(f"y_{a}_{i}" for a in XYZ))
        d = take(*(f"d_{a}_{i}" for a in XYZ))
        s = take(*(f"std_y_{a}_{i}" for a in XYZ))
        for what, v in ((f"y_*_{i}", y), (f"d_*_{i}", d)):
            part = np.isnan(v).any(axis=1) & ~np.isnan(v).all(axis=1)
            if part.any() or np.isinf(v).any():
                raise _fail(src, _first_bad(part | np.isinf(v).any(axis=1)),
                            f"{what}: all three given (finite) or all NaN")
        has = np.isfinite(y[:, 0]) & np.isfinite(d[:, 0])
        if not np.all(_unit(d[has], UNIT_TOL)):
            rows_ = np.flatnonzero(has)[~_unit(d[has], UNIT_TOL)]
            raise _fail(src, int(rows_[0]) + 2, f"d_*_{i}: not a unit direction")
        n = np.linalg.norm(y[has], axis=1)
        if not np.all((n > 0.5) & (n < 1.5)):
            raise _fail(src, int(np.flatnonzero(has)[~((n > 0.5) & (n < 1.5))][0]) + 2,
                        f"y_*_{i}: a unit reading must have a length in (0.5, 1.5)")
        ok_s = np.isfinite(s) & (s > 0) & (s**2 >= TINY) & (s <= 10.0)
        if not np.all(ok_s[has]):
            raise _fail(src, int(np.flatnonzero(has & ~ok_s.all(axis=1))[0]) + 2,
                        f"std_y_*_{i}: must be in (0, 10] (its square not underflowing) "
                        f"where sensor {i} reads")
        if f"cq_w_{i}" in col:
            cq = take(*(f"cq_{a}_{i}" for a in WXYZ))
            good = np.all(np.isfinite(cq), axis=1) & _unit(np.nan_to_num(cq), NORM_TOL)
            if not np.all(good):
                raise _fail(src, _first_bad(~good), f"cq_*_{i}: not a unit quaternion")
            yb = np.full_like(y, np.nan)
            yb[has] = qrotate(cq[has], y[has] / n[:, None])
        else:
            yb = np.full_like(y, np.nan)
            yb[has] = y[has] / n[:, None]
        body[:, i], refs[:, i], seen[:, i] = yb, d, has
        sigma[:, i] = np.where(has[:, None], s, np.nan)
    if not seen.any():
        raise _fail(src, None, "no row has a direction reading: nothing to correct the gyro")
    return AttitudeRecord(t, q / np.linalg.norm(q, axis=1, keepdims=True), base[:, 5:8],
                          base[:, 8:11], noise[0, :3].copy(), noise[0, 3:].copy(), body, refs,
                          sigma, seen, src)


def read_attitude_log(path: str | os.PathLike) -> AttitudeRecord:
    """Read an ``EqFdata.csv``-layout file; unreadable or malformed input raises
    :class:`LogFormatError`."""
    src = os.fspath(path)
    limits.check_file(Path(path), lambda why: LogFormatError(src, None, why))
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise LogFormatError(src, None, f"not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise LogFormatError(src, None, f"cannot read ({exc.strerror or exc})") from None
    text = text.removeprefix("\ufeff")  # a byte-order mark
    if "\x00" in text:
        raise LogFormatError(src, None, "binary data (a NUL byte)")
    return parse_attitude_log(text, src)


def is_attitude_log(path: Path) -> bool:
    """Whether ``path``'s first line is an EqFdata.csv-layout header (for ``--log``): a
    time column ``t`` and the gyro columns ``w_x``... (an IMU + GNSS CSV names its gyro
    ``gx``...), so a file of that layout with a column missing still reaches this reader
    and its error."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            first = f.readline(4096)
    except (OSError, ValueError):
        return False
    cols = {c.strip() for c in first.removeprefix("\ufeff").split(",")}
    return "t" in cols and "w_x" in cols and "gx" not in cols

