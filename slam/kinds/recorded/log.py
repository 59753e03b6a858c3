"""Recorded planar SLAM logs in GTSAM's text format: the log value, parsing, writing.

File format (one record a line; blank lines and ``#`` comments are skipped)::

    ODOMETRY i j dx dy dθ  c_xx c_xy c_xθ c_yy c_yθ c_θθ
    LANDMARK i l x y  c_xx c_xy c_yy

See :mod:`slam.kinds.recorded` for the meaning of the fields.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from estimators.linalg import Array

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


def _int(tok: str, what: str, src: str, line: int) -> int:
    try:
        v = int(tok)
    except ValueError:
        raise LogFormatError(src, line, f"{what} {tok!r} is not an integer id") from None
    if v < 0:
        raise LogFormatError(src, line, f"{what} {v} is negative")
    return v


def _floats(toks: list[str], what: str, src: str, line: int) -> list[float]:
    out = []
    for t in toks:
        try:
            v = float(t)
        except ValueError:
            raise LogFormatError(src, line, f"{what}: {t!r} is not a number") from None
        if not math.isfinite(v):
            raise LogFormatError(src, line, f"{what}: {t!r} is not finite")
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


def parse_odometry_log(text: str, source: str = "<text>") -> OdometryLog:
    """Parse GTSAM's planar ``ODOMETRY``/``LANDMARK`` text; raises :class:`LogFormatError`."""
    chain: list[int] = []
    where_pose: dict[int, int] = {}   # pose id -> line that introduced it
    odo, odo_cov = [], []
    lms: list[tuple[int, int, int, list[float], Array]] = []   # (line, pose, id, xy, cov)
    for no, raw in enumerate(text.splitlines(), start=1):
        s = raw.split("#", 1)[0].strip()
        if not s:
            continue
        tok = s.split()
        tag = tok[0]
        if tag not in _COUNTS:
            raise LogFormatError(source, no, f"unknown record {tag!r} (this reader knows "
                                 "ODOMETRY and LANDMARK lines)")
        if len(tok) != _COUNTS[tag]:
            raise LogFormatError(source, no, f"{tag} needs {_COUNTS[tag] - 1} fields "
                                 f"({_LAYOUT[tag]}), got {len(tok) - 1}")
        i = _int(tok[1], "pose id", source, no)
        if tag == "ODOMETRY":
            j = _int(tok[2], "pose id", source, no)
            delta = _floats(tok[3:6], "motion", source, no)
            C = _upper_to_cov(_floats(tok[6:12], "covariance", source, no), 3)
            _check_cov(C, source, no)
            if not chain:
                chain.append(i)
                where_pose[i] = no
            elif i != chain[-1]:
                raise LogFormatError(source, no, f"ODOMETRY {i} {j}: the odometry must form "
                                     f"one chain, but the last pose is {chain[-1]}")
            if j in where_pose:
                raise LogFormatError(source, no, f"ODOMETRY {i} {j}: pose {j} already "
                                     f"appeared (line {where_pose[j]})")
            chain.append(j)
            where_pose[j] = no
            odo.append(delta)
            odo_cov.append(C)
        else:
            lid = _int(tok[2], "landmark id", source, no)
            xy = _floats(tok[3:5], "landmark point", source, no)
            C = _upper_to_cov(_floats(tok[5:8], "covariance", source, no), 2)
            _check_cov(C, source, no)
            lms.append((no, i, lid, xy, C))
    if not chain:
        if lms:   # landmarks only: a single pose
            chain.append(lms[0][1])
            where_pose[lms[0][1]] = lms[0][0]
        else:
            raise LogFormatError(source, None, "no ODOMETRY or LANDMARK records")
    index = {p: k for k, p in enumerate(chain)}
    obs_pose, obs_id, obs, obs_cov = [], [], [], []
    for no, i, lid, xy, C in lms:
        if i not in index:
            raise LogFormatError(source, no, f"LANDMARK {i} {lid}: pose {i} is not on the "
                                 "odometry chain")
        if lid in where_pose:
            raise LogFormatError(source, no, f"LANDMARK {i} {lid}: id {lid} is also a pose "
                                 f"id (line {where_pose[lid]}); pose and landmark ids share "
                                 "one space")
        obs_pose.append(index[i])
        obs_id.append(lid)
        obs.append(xy)
        obs_cov.append(C)
    order = np.argsort(np.asarray(obs_pose, dtype=np.int64), kind="stable")
    return OdometryLog(
        pose_ids=np.asarray(chain, dtype=np.int64),
        odometry=np.asarray(odo, dtype=float).reshape(-1, 3),
        odometry_cov=np.asarray(odo_cov, dtype=float).reshape(-1, 3, 3),
        obs_pose=np.asarray(obs_pose, dtype=np.int64)[order],
        obs_id=np.asarray(obs_id, dtype=np.int64)[order],
        obs=np.asarray(obs, dtype=float).reshape(-1, 2)[order],
        obs_cov=np.asarray(obs_cov, dtype=float).reshape(-1, 2, 2)[order],
        source=source,
    )


def read_odometry_log(path: str | os.PathLike) -> OdometryLog:
    """Read a log file; unreadable or malformed input raises :class:`LogFormatError`."""
    src = os.fspath(path)
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


