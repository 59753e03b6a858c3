"""Recorded planar SLAM logs in GTSAM's text format: the log value, parsing, writing.

File format (one record a line; blank lines and ``#`` comments are skipped)::

    ODOMETRY i j dx dy dθ  c_xx c_xy c_xθ c_yy c_yθ c_θθ
    LANDMARK i l x y  c_xx c_xy c_yy

See :mod:`slam.kinds.recorded` for the meaning of the fields.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from estimators.linalg import Array
from worlds import limits

#: Filters run on a recorded log by default.
DEFAULT_FILTERS: tuple[str, ...] = ("ekf", "srckf", "srukf", "srcdkf")
#: At most this many odometry steps are compounded into one prediction.
DEFAULT_MAX_EPOCH_STEPS = 25
#: Prior standard deviation (m, m, rad) holding the smoother's first pose at the origin.
PRIOR_SIGMA = 1e-6


class LogFormatError(ValueError):
    """A malformed recorded log; ``str()`` is ``file:line: message``."""

    def __init__(self, source: str, line: int | None, message: str):
        self.source, self.line, self.message = source, line, message
        where = source if line is None else f"{source}:{line}"
        super().__init__(f"{where}: {message}")

    def __reduce__(self) -> tuple[type, tuple[str, int | None, str]]:
        return (LogFormatError, (self.source, self.line, self.message))


# --------------------------------------------------------------------------- the log value

@dataclass(frozen=True, eq=False)
class OdometryLog:
    """A recorded odometry + landmark log (no ground truth).

    Attributes
    ----------
    pose_ids : (P,) int array, the poses in chain order.
    odometry : (P - 1, 3) ``[dx, dy, dθ]`` from pose ``k`` to ``k + 1`` in pose ``k``'s frame.
    odometry_cov : (P - 1, 3, 3) their covariances (between-factor tangent).
    obs_pose : (M,) int array, chain index of the observing pose (non-decreasing).
    obs_id : (M,) int array, landmark ids.
    obs : (M, 2) landmark points ``[x, y]`` in the robot frame.
    obs_cov : (M, 2, 2) their covariances.
    source : where the log was read from.
    """

    pose_ids: NDArray[np.int64]
    odometry: Array
    odometry_cov: Array
    obs_pose: NDArray[np.int64]
    obs_id: NDArray[np.int64]
    obs: Array
    obs_cov: Array
    source: str = field(default="<memory>")

    @property
    def n_poses(self) -> int:
        return int(len(self.pose_ids))

    @property
    def landmark_ids(self) -> NDArray[np.int64]:
        return np.unique(self.obs_id)

    def observations_at(self) -> dict[int, slice]:
        """Map chain index -> slice of the observations taken at that pose."""
        steps, first = np.unique(self.obs_pose, return_index=True)
        last = np.append(first[1:], len(self.obs_pose))
        return {int(k): slice(int(a), int(b)) for k, a, b in zip(steps, first, last)}

    def prefix(self, n_poses: int) -> OdometryLog:
        """The first ``n_poses`` poses of the chain and the observations taken from them."""
        n = max(1, min(int(n_poses), self.n_poses))
        m = int(np.searchsorted(self.obs_pose, n))
        return OdometryLog(self.pose_ids[:n], self.odometry[:n - 1], self.odometry_cov[:n - 1],
                           self.obs_pose[:m], self.obs_id[:m], self.obs[:m], self.obs_cov[:m],
                           self.source)

    def equals(self, other: OdometryLog) -> bool:
        """Exact equality of every array (``source`` aside)."""
        names = ("pose_ids", "odometry", "odometry_cov", "obs_pose", "obs_id", "obs",
                 "obs_cov")
        return all(np.array_equal(getattr(self, n), getattr(other, n)) for n in names)


# --------------------------------------------------------------------------- parsing

_COUNTS = {"ODOMETRY": 12, "LANDMARK": 8}
_LAYOUT = {"ODOMETRY": "ODOMETRY i j dx dy dθ cxx cxy cxθ cyy cyθ cθθ",
           "LANDMARK": "LANDMARK i l x y cxx cxy cyy"}


_INT = re.compile(r"[+-]?[0-9]+")
_NUMBER = re.compile(r"[+-]?(([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?|inf|infinity|nan)",
                     re.IGNORECASE)
#: Largest pose or landmark id (GTSAM keeps 56 bits for a symbol's index).
MAX_ID = 2**56 - 1
#: Largest magnitude of a coordinate (m), an angle (rad) or a covariance entry.
MAX_VALUE = 1e6
#: Allowed eigenvalues of a covariance (variances from (1 µm)² to (1 km)²).
VARIANCE_RANGE = (1e-12, 1e6)
#: Smallest range of a landmark point (a point at the robot has no bearing).
MIN_RANGE_M = 1e-6


#: Digits of :data:`MAX_ID`: a longer id is refused before it is converted (Python refuses
#: to convert more than 4300 digits, and a long one costs time quadratic in its length).
MAX_ID_DIGITS = len(str(MAX_ID))


def _shown(tok: str, limit: int = 40) -> str:
    """A token for a message, cut to ``limit`` characters with its length."""
    return tok if len(tok) <= limit else f"{tok[:20]}...({len(tok)} characters)"


def _int(tok: str, what: str, src: str, line: int) -> int:
    if not _INT.fullmatch(tok):  # no "1_000", no non-ASCII digits
        raise LogFormatError(src, line, f"{what} {_shown(tok)!r} is not an integer id")
    digits = tok.lstrip("+-").lstrip("0")
    if tok.startswith("-") and digits:
        raise LogFormatError(src, line, f"{what} {_shown(tok)} is negative")
    if len(digits) > MAX_ID_DIGITS or int(digits or "0") > MAX_ID:
        raise LogFormatError(src, line, f"{what} {_shown(tok)} is too large (at most 2**56 - 1 "
                             f"= {MAX_ID}, GTSAM's key index)")
    return int(digits or "0")


def _floats(toks: list[str], what: str, src: str, line: int) -> list[float]:
    out = []
    for t in toks:
        if not _NUMBER.fullmatch(t):
            raise LogFormatError(src, line, f"{what}: {_shown(t)!r} is not a number")
        v = float(t)
        if not math.isfinite(v):
            raise LogFormatError(src, line, f"{what}: {_shown(t)!r} is not finite")
        if abs(v) > MAX_VALUE:
            raise LogFormatError(src, line, f"{what}: {_shown(t)} is beyond +-{MAX_VALUE:g}")
        out.append(v)
    return out


def _upper_to_cov(v: list[float], n: int) -> Array:
    C = np.zeros((n, n))
    C[np.triu_indices(n)] = v
    return C + np.triu(C, 1).T


def _check_cov(C: Array, src: str, line: int) -> None:
    try:
        np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        diag = ", ".join(f"{d:g}" for d in np.diagonal(C))
        raise LogFormatError(src, line, f"covariance (diagonal {diag}) is not positive "
                             "definite") from None
    w = np.linalg.eigvalsh(C)
    lo, hi = VARIANCE_RANGE
    if w[0] < lo or w[-1] > hi:
        raise LogFormatError(src, line, f"covariance eigenvalues {w[0]:g} .. {w[-1]:g} are "
                             f"outside [{lo:g}, {hi:g}]")


class _Reader:
    """The records of a log, line by line: the odometry chain and the sightings."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.chain: list[int] = []
        self.where_pose: dict[int, int] = {}   # pose id -> line that introduced it
        self.odo: list[list[float]] = []
        self.odo_cov: list[Array] = []
        self.lms: list[tuple[int, int, int, list[float], Array]] = []  # line, pose, id, xy, C

    def error(self, line: int | None, message: str) -> LogFormatError:
        return LogFormatError(self.source, line, message)

    def record(self, no: int, tok: list[str]) -> None:
        tag = tok[0]
        if tag not in _COUNTS:
            raise self.error(no, f"unknown record {tag!r} (this reader knows ODOMETRY and "
                             "LANDMARK lines)")
        if len(tok) != _COUNTS[tag]:
            raise self.error(no, f"{tag} needs {_COUNTS[tag] - 1} fields ({_LAYOUT[tag]}), "
                             f"got {len(tok) - 1}")
        (self.odometry if tag == "ODOMETRY" else self.landmark)(no, tok)

    def _fields(self, no: int, tok: list[str], second: str, what: str, dim: int
                ) -> tuple[int, int, list[float], Array]:
        """``(pose id, second id, values, covariance)`` of a record of ``dim`` values."""
        src = self.source
        i, j = _int(tok[1], "pose id", src, no), _int(tok[2], second, src, no)
        values = _floats(tok[3:3 + dim], what, src, no)
        C = _upper_to_cov(_floats(tok[3 + dim:], "covariance", src, no), dim)
        _check_cov(C, src, no)
        return i, j, values, C

    def odometry(self, no: int, tok: list[str]) -> None:
        i, j, delta, C = self._fields(no, tok, "pose id", "motion", 3)
        if not self.chain:
            self.chain.append(i)
            self.where_pose[i] = no
        elif i != self.chain[-1]:
            raise self.error(no, f"ODOMETRY {i} {j}: the odometry must form one chain, but "
                             f"the last pose is {self.chain[-1]}")
        if j in self.where_pose:
            raise self.error(no, f"ODOMETRY {i} {j}: pose {j} already appeared (line "
                             f"{self.where_pose[j]})")
        self.chain.append(j)
        self.where_pose[j] = no
        self.odo.append(delta)
        self.odo_cov.append(C)

    def landmark(self, no: int, tok: list[str]) -> None:
        i, lid, xy, C = self._fields(no, tok, "landmark id", "landmark point", 2)
        if not math.hypot(*xy) >= MIN_RANGE_M:
            raise self.error(no, f"LANDMARK {i} {lid}: the point {xy} is at the robot (range "
                             f"below {MIN_RANGE_M:g} m: no bearing)")
        self.lms.append((no, i, lid, xy, C))

    def sightings(self) -> tuple[list[int], list[int], list[list[float]], list[Array]]:
        """Each sighting's chain index, landmark id, point and covariance."""
        if not self.chain:
            if not self.lms:
                raise self.error(None, "no ODOMETRY or LANDMARK records")
            self.chain.append(self.lms[0][1])  # landmarks only: a single pose
            self.where_pose[self.lms[0][1]] = self.lms[0][0]
        index = {p: k for k, p in enumerate(self.chain)}
        obs_pose, obs_id, obs, obs_cov = [], [], [], []
        for no, i, lid, xy, C in self.lms:
            if i not in index:
                raise self.error(no, f"LANDMARK {i} {lid}: pose {i} is not on the odometry "
                                 "chain")
            if lid in self.where_pose:
                raise self.error(no, f"LANDMARK {i} {lid}: id {lid} is also a pose id (line "
                                 f"{self.where_pose[lid]}); pose and landmark ids share one "
                                 "space")
            obs_pose.append(index[i])
            obs_id.append(lid)
            obs.append(xy)
            obs_cov.append(C)
        return obs_pose, obs_id, obs, obs_cov


def parse_odometry_log(text: str, source: str = "<text>") -> OdometryLog:
    """Parse GTSAM's planar ``ODOMETRY``/``LANDMARK`` text; raises :class:`LogFormatError`."""
    reader = _Reader(source)
    for no, raw in enumerate(text.splitlines(), start=1):
        s = raw.split("#", 1)[0].strip()
        if s:
            reader.record(no, s.split())
    obs_pose, obs_id, obs, obs_cov = reader.sightings()
    order = np.argsort(np.asarray(obs_pose, dtype=np.int64), kind="stable")
    return OdometryLog(
        pose_ids=np.asarray(reader.chain, dtype=np.int64),
        odometry=np.asarray(reader.odo, dtype=float).reshape(-1, 3),
        odometry_cov=np.asarray(reader.odo_cov, dtype=float).reshape(-1, 3, 3),
        obs_pose=np.asarray(obs_pose, dtype=np.int64)[order],
        obs_id=np.asarray(obs_id, dtype=np.int64)[order],
        obs=np.asarray(obs, dtype=float).reshape(-1, 2)[order],
        obs_cov=np.asarray(obs_cov, dtype=float).reshape(-1, 2, 2)[order],
        source=source,
    )


def read_odometry_log(path: str | os.PathLike) -> OdometryLog:
    """Read a log file; unreadable or malformed input raises :class:`LogFormatError`."""
    src = os.fspath(path)
    limits.check_file(Path(path), lambda why: LogFormatError(src, None, why))
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LogFormatError(src, None, "file not found") from None
    except UnicodeDecodeError as exc:
        raise LogFormatError(src, None, f"not UTF-8 text ({exc})") from None
    except OSError as exc:
        raise LogFormatError(src, None, f"cannot read ({exc.strerror or exc})") from None
    return parse_odometry_log(text, src)


def format_odometry_log(log: OdometryLog) -> str:
    """The log as text in the same format (floats exact: ``repr``), poses in chain order,
    each pose's ``LANDMARK`` lines after the ``ODOMETRY`` line that reaches it."""
    iu3, iu2 = np.triu_indices(3), np.triu_indices(2)
    by_pose = log.observations_at()
    lines = []

    def landmarks(k: int) -> None:
        sl = by_pose.get(k)
        if sl is None:
            return
        for lid, xy, C in zip(log.obs_id[sl], log.obs[sl], log.obs_cov[sl]):
            vals = " ".join(repr(float(v)) for v in (*xy, *C[iu2]))
            lines.append(f"LANDMARK {int(log.pose_ids[k])} {int(lid)} {vals}")

    landmarks(0)
    for k in range(1, log.n_poses):
        d, C = log.odometry[k - 1], log.odometry_cov[k - 1]
        vals = " ".join(repr(float(v)) for v in (*d, *C[iu3]))
        lines.append(f"ODOMETRY {int(log.pose_ids[k - 1])} {int(log.pose_ids[k])} {vals}")
        landmarks(k)
    return "\n".join(lines) + "\n"


