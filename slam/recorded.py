r"""Recorded planar SLAM logs in GTSAM's text format: reading, filtering, smoothing, scoring.

File format (one record a line; blank lines and ``#`` comments are skipped)::

    ODOMETRY i j dx dy dθ  c_xx c_xy c_xθ c_yy c_yθ c_θθ
    LANDMARK i l x y  c_xx c_xy c_yy

``ODOMETRY`` is the motion from pose ``i`` to pose ``j`` in the frame of pose ``i``
(metres, radians) with the upper triangle, row by row, of its covariance in GTSAM's
between-factor tangent (body frame of the motion, right perturbation:
:math:`T_j = T_i\,\Delta\,\mathrm{Exp}(w)`, :math:`w \sim N(0, C)`).  ``LANDMARK`` is
landmark ``l`` seen from pose ``i`` as a Cartesian point ``(x, y)`` in the robot frame,
with the upper triangle of its covariance.  Landmark ids are known; pose and landmark ids
share one integer space, so pose ids have gaps.  (This is the layout of the wheel's
``victoria_park.txt``: ``ODOMETRY`` covariance diag(1e-4, 4e-6, 4e-6), ``LANDMARK``
covariance diag(0.4, 0.4); GTSAM's own ``load2D`` reads the same triangles as covariances.)
The odometry records must form one chain (each starts where the previous one ended).

Filter models (state :math:`[x, y, φ, m_1, \dots]`, the layout of :mod:`slam.planar_models`)

.. math::

    T' = T\,\Delta\,\mathrm{Exp}(w)\ \text{(per odometry step, noise entering the
    increment)},\qquad
    z = R(φ)^\top (m - p) + v,\qquad
    m = p + R(φ)\,(z + v)\ \text{(augmentation)}.

The filters start at the first pose, known exactly (the origin), as the smoother's prior.

The smoother (:func:`smooth_recorded`)
    ``BetweenFactorPose2`` per odometry record with the file's covariance, and one
    ``BearingRangeFactor2D`` per landmark record: the GTSAM 4.3 wheel has no built-in
    factor for a Cartesian point in a pose's frame (``KnownLandmarkFactorPose2`` holds the
    landmark fixed), so the measurement is converted to bearing :math:`b = \mathrm{atan2}(y,
    x)` and range :math:`r = \lVert(x, y)\rVert` with the first-order covariance
    :math:`J C J^\top`, :math:`J = \partial(b, r)/\partial(x, y)` - for an isotropic
    :math:`C = σ^2 I` that is :math:`σ_b = σ/r`, :math:`σ_r = σ`, and the two factors' errors
    agree to second order in the residual.  A weak prior (1e-6) holds the first pose at
    the origin.  Levenberg-Marquardt from dead reckoning falls into a wrong minimum on a
    long log, so the poses are fed one by one to iSAM2 (each new pose initialised from the
    current estimate of the previous one and the odometry, each new landmark from its
    first sighting), and a final batch LM polishes the result; ``½χ²`` (``graph.error``)
    is reported after each.

Scoring (:func:`score_filter`)
    Without ground truth the filters are scored against the smoother: per filter the
    median and maximum distance of its final landmarks to the smoother's, the distance of
    its final pose to the smoother's final pose, its pose RMSE to the smoother over the
    filter epochs, and its whole-log time.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators import Euclidean, Measurement, Noise, Transition, wrap_angle
from estimators.linalg import Array

from .joint import PLANAR_LAYOUT, SlamProblem, SlamResult, run_problem
from .planar_models import state_space

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


# --------------------------------------------------------------------------- filter models

def pose2_exp(w: Array) -> Array:
    r"""``Pose2.Expmap`` of rows ``[v_x, v_y, ω]`` -> ``[x, y, θ]`` (vectorised)."""
    th = w[:, 2]
    small = np.abs(th) < 1e-5
    ts = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th**2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, th / 2.0 - th**3 / 24.0, (1.0 - np.cos(ts)) / ts)
    out = np.empty_like(w)
    out[:, 0] = a * w[:, 0] - b * w[:, 1]
    out[:, 1] = b * w[:, 0] + a * w[:, 1]
    out[:, 2] = th
    return out


def pose2_compose(P: Array, D: Array) -> Array:
    """``P ∘ D`` for rows of poses ``[x, y, θ]`` (broadcasting), θ wrapped."""
    c, s = np.cos(P[..., 2]), np.sin(P[..., 2])
    out = np.empty(np.broadcast_shapes(P.shape, D.shape))
    out[..., 0] = P[..., 0] + c * D[..., 0] - s * D[..., 1]
    out[..., 1] = P[..., 1] + s * D[..., 0] + c * D[..., 1]
    out[..., 2] = wrap_angle(P[..., 2] + D[..., 2])
    return out


def odometry_model(sqrt_covs: Array) -> Transition:
    r"""Joint-state transition over ``len(sqrt_covs)`` odometry steps; landmarks stay.

    ``u`` is the (s, 3) block of increments; the noise ``W`` (m, 3s) holds each step's
    increment error (``sqrt_covs`` (s, 3, 3) their lower factors):
    :math:`T \leftarrow T\,\Delta_i\,\mathrm{Exp}(w_i)`.  EKF Jacobians chain the
    per-step ones along the mean path, :math:`F_i = [[I, J R(θ_i)Δ_i],[0, 1]]`,
    :math:`G_i = \mathrm{blkdiag}(R(θ_{i+1}), 1)`.
    """
    sqrt_covs = np.asarray(sqrt_covs, dtype=float)
    s = len(sqrt_covs)
    sq = np.zeros((3 * s, 3 * s))
    for i, L in enumerate(sqrt_covs):
        sq[3 * i:3 * i + 3, 3 * i:3 * i + 3] = L

    def f(X: Array, u: Array, W: Array) -> Array:
        Y = X.copy()
        px, py, pt = X[:, 0].copy(), X[:, 1].copy(), X[:, 2].copy()
        for i in range(s):
            # E = Exp(w) (sinc forms, exact at 0), D = Δ_i ∘ E, P = P ∘ D
            vx, vy, th = W[:, 3 * i], W[:, 3 * i + 1], W[:, 3 * i + 2]
            a = np.sinc(th / np.pi)
            half = np.sin(0.5 * th)
            b = half * np.sinc(th / (2.0 * np.pi))
            ex, ey = a * vx - b * vy, b * vx + a * vy
            cu, su = math.cos(u[i, 2]), math.sin(u[i, 2])
            dx, dy = u[i, 0] + cu * ex - su * ey, u[i, 1] + su * ex + cu * ey
            c, sn = np.cos(pt), np.sin(pt)
            px += c * dx - sn * dy
            py += sn * dx + c * dy
            pt += u[i, 2] + th
        Y[:, 0], Y[:, 1], Y[:, 2] = px, py, wrap_angle(pt)
        return Y

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        n = x.shape[0]
        Fv = np.eye(3)
        Gv = np.zeros((3, 3 * s))
        p = np.asarray(x[:3], dtype=float)
        for i in range(s):
            c, sn = np.cos(p[2]), np.sin(p[2])
            dx, dy = c * u[i, 0] - sn * u[i, 1], sn * u[i, 0] + c * u[i, 1]
            Fi = np.eye(3)
            Fi[0, 2], Fi[1, 2] = -dy, dx
            p = pose2_compose(p, np.asarray(u[i], dtype=float))
            c1, s1 = np.cos(p[2]), np.sin(p[2])
            Gi = np.array([[c1, -s1, 0.0], [s1, c1, 0.0], [0.0, 0.0, 1.0]])
            Fv = Fi @ Fv
            Gv = Fi @ Gv
            Gv[:, 3 * i:3 * i + 3] = Gi
        F = np.eye(n)
        F[:3, :3] = Fv
        Gm = np.zeros((n, 3 * s))
        Gm[:3] = Gv
        return F, Gm

    return Transition(f, Noise.from_sqrt(sq), additive=False, jacobian=jacobian)


def _block_noise(covs: Array) -> Noise:
    k = len(covs)
    C = np.zeros((2 * k, 2 * k))
    for i, c in enumerate(covs):
        C[2 * i:2 * i + 2, 2 * i:2 * i + 2] = c
    return Noise.from_cov(C)


def point_in_robot(X: Array, slots: Array) -> Array:
    """Stacked ``R(φ)ᵀ (m - p)`` of the landmarks at ``slots`` from states ``X`` (m, n)."""
    cols = 3 + 2 * np.asarray(slots)
    dx = X[:, cols] - X[:, :1]
    dy = X[:, cols + 1] - X[:, 1:2]
    c, s = np.cos(X[:, 2:3]), np.sin(X[:, 2:3])
    Z = np.empty((X.shape[0], 2 * len(cols)))
    Z[:, 0::2] = c * dx + s * dy
    Z[:, 1::2] = -s * dx + c * dy
    return Z


def point_observation_model(slots: Array, covs: Array) -> Measurement:
    """Cartesian robot-frame observation of the landmarks at ``slots`` (``covs`` (k, 2, 2))."""
    slots = np.asarray(slots, dtype=int)

    def jacobian(x: Array) -> Array:
        H = np.zeros((2 * len(slots), x.shape[0]))
        c, s = np.cos(x[2]), np.sin(x[2])
        Rt = np.array([[c, s], [-s, c]])
        z = point_in_robot(x[None, :], slots)[0]
        for i, sl in enumerate(slots):
            col = 3 + 2 * int(sl)
            r = slice(2 * i, 2 * i + 2)
            H[r, 0:2] = -Rt
            H[r, 2] = [z[2 * i + 1], -z[2 * i]]
            H[r, col:col + 2] = Rt
        return H

    return Measurement(lambda X: point_in_robot(X, slots), _block_noise(covs),
                       space=Euclidean(2 * len(slots)), jacobian=jacobian)


def point_augmentation_model(n_landmarks: int, z_new: Array, covs: Array) -> Transition:
    """Append the landmarks first seen as robot-frame points ``z_new`` (2k,):
    :math:`s' = [s;\\ p + R(φ)(z + v)]`, the observation noise ``v`` a model input."""
    k = len(z_new) // 2
    n = 3 + 2 * n_landmarks

    def f(X: Array, u: Array, W: Array) -> Array:
        Z = u + W
        c, s = np.cos(X[:, 2:3]), np.sin(X[:, 2:3])
        new = np.empty((X.shape[0], 2 * k))
        new[:, 0::2] = X[:, :1] + c * Z[:, 0::2] - s * Z[:, 1::2]
        new[:, 1::2] = X[:, 1:2] + s * Z[:, 0::2] + c * Z[:, 1::2]
        return np.hstack([X, new])

    def jacobian(x: Array, u: Array) -> tuple[Array, Array]:
        F = np.zeros((n + 2 * k, n))
        F[:n] = np.eye(n)
        Gm = np.zeros((n + 2 * k, 2 * k))
        c, s = np.cos(x[2]), np.sin(x[2])
        for i in range(k):
            zx, zy = u[2 * i], u[2 * i + 1]
            row = n + 2 * i
            F[row, [0, 2]] = [1.0, -s * zx - c * zy]
            F[row + 1, [1, 2]] = [1.0, c * zx - s * zy]
            Gm[row:row + 2, 2 * i:2 * i + 2] = [[c, -s], [s, c]]
        return F, Gm

    return Transition(f, _block_noise(covs), additive=False, space=state_space(n_landmarks + k),
                      jacobian=jacobian)


def recorded_epochs(log: OdometryLog, max_steps: int = DEFAULT_MAX_EPOCH_STEPS) -> Array:
    """Filter epochs (chain indices): 0, every pose with observations, the last pose, and
    enough in between that no prediction compounds more than ``max_steps`` steps."""
    K = log.n_poses - 1
    ev = np.unique(np.concatenate([[0, K], log.obs_pose])).astype(np.int64)
    out = [int(ev[0])]
    for k in ev[1:]:
        while k - out[-1] > max_steps:
            out.append(out[-1] + max_steps)
        out.append(int(k))
    return np.asarray(out, dtype=np.int64)


def recorded_problem(log: OdometryLog, *, max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS
                     ) -> SlamProblem:
    """The :class:`~slam.joint.SlamProblem` of a recorded log (known ids, no truth)."""
    sq = np.linalg.cholesky(log.odometry_cov) if len(log.odometry_cov) else np.zeros((0, 3, 3))
    models: dict[bytes, Transition] = {}   # logs often repeat one covariance

    def motion(k0: int, k1: int) -> tuple[Transition, Array]:
        key = sq[k0:k1].tobytes()
        if key not in models:
            models[key] = odometry_model(sq[k0:k1])
        return models[key], log.odometry[k0:k1]

    return SlamProblem(
        x0=np.zeros(3), P0=np.zeros((3, 3)), steps=recorded_epochs(log, max_epoch_steps),
        motion=motion, observations=log.observations_at(), obs=log.obs, obs_id=log.obs_id,
        observe=lambda slots, index: point_observation_model(slots, log.obs_cov[index]),
        augment=lambda n, z, index: point_augmentation_model(n, z, log.obs_cov[index]),
        layout=PLANAR_LAYOUT, truth=None, nearest=None)


def run_recorded(log: OdometryLog, filter_name: str, *, mode: str = "local",
                 max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS,
                 filter_params: dict | None = None) -> SlamResult:
    """Run one filter over a recorded log (the one loop of :func:`slam.joint.run_problem`)."""
    return run_problem(recorded_problem(log, max_epoch_steps=max_epoch_steps), filter_name,
                       mode=mode, filter_params=filter_params)


def dead_reckoning_poses(log: OdometryLog) -> Array:
    """The compounded odometry, (P, 3), from the origin."""
    out = np.zeros((log.n_poses, 3))
    for k in range(1, log.n_poses):
        out[k] = pose2_compose(out[k - 1], log.odometry[k - 1])
    return out


# --------------------------------------------------------------------------- the smoother

@dataclass(frozen=True)
class RecordedReference:
    """The smoother's estimate of a recorded log.

    poses : (P, 3) in chain order; landmark_ids (L,) ascending; landmarks (L, 2);
    objective / objective_isam2 : ``½χ²`` after the LM polish / after iSAM2;
    time_isam2_s, time_lm_s, time_s : wall times (iSAM2 includes building the graph).
    """

    poses: Array
    landmark_ids: NDArray[np.int64]
    landmarks: Array
    objective: float
    objective_isam2: float
    time_isam2_s: float
    time_lm_s: float
    time_s: float


def bearing_range(z: Array, cov: Array) -> tuple[float, float, Array]:
    """``(bearing, range, covariance [b, r])`` of a robot-frame point, first order."""
    x, y = float(z[0]), float(z[1])
    r2 = x * x + y * y
    r = math.sqrt(r2)
    J = np.array([[-y / r2, x / r2], [x / r, y / r]])
    return math.atan2(y, x), r, J @ cov @ J.T


def smooth_recorded(log: OdometryLog, *, lm_iterations: int = 100) -> RecordedReference:
    """Smooth a recorded log with GTSAM: iSAM2 pose by pose, then a batch LM polish."""
    import gtsam
    from gtsam.symbol_shorthand import L, X

    t0 = time.perf_counter()
    noise_cache: dict[bytes, Any] = {}

    def noise(C: Array):
        key = C.tobytes()
        if key not in noise_cache:
            if not np.any(C - np.diag(np.diagonal(C))):
                noise_cache[key] = gtsam.noiseModel.Diagonal.Variances(np.diagonal(C).copy())
            else:
                noise_cache[key] = gtsam.noiseModel.Gaussian.Covariance(C)
        return noise_cache[key]

    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(0.1)
    params.relinearizeSkip = 1
    isam = gtsam.ISAM2(params)
    graph = gtsam.NonlinearFactorGraph()
    by_pose = log.observations_at()
    seen: set[int] = set()
    ids = log.pose_ids
    pose_est = gtsam.Pose2(0.0, 0.0, 0.0)
    for k in range(log.n_poses):
        new_f = gtsam.NonlinearFactorGraph()
        new_v = gtsam.Values()
        key = X(int(ids[k]))
        if k == 0:
            new_f.add(gtsam.PriorFactorPose2(key, pose_est,
                                             gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)))
        else:
            delta = gtsam.Pose2(*log.odometry[k - 1])
            new_f.add(gtsam.BetweenFactorPose2(X(int(ids[k - 1])), key, delta,
                                               noise(log.odometry_cov[k - 1])))
            pose_est = pose_est.compose(delta)
        new_v.insert(key, pose_est)
        sl = by_pose.get(k)
        if sl is not None:
            for lid, z, C in zip(log.obs_id[sl], log.obs[sl], log.obs_cov[sl]):
                b, r, Cbr = bearing_range(z, C)
                lid = int(lid)
                if abs(Cbr[0, 1]) > 0.0:
                    nm = gtsam.noiseModel.Gaussian.Covariance(Cbr)
                else:
                    nm = gtsam.noiseModel.Diagonal.Sigmas(np.sqrt(np.diagonal(Cbr)))
                new_f.add(gtsam.BearingRangeFactor2D(key, L(lid), gtsam.Rot2(b), r, nm))
                if lid not in seen:
                    seen.add(lid)
                    new_v.insert(L(lid), pose_est.transformFrom(np.asarray(z, dtype=float)))
        graph.push_back(new_f)
        isam.update(new_f, new_v)
        pose_est = isam.calculateEstimatePose2(key)
    est = isam.calculateEstimate()
    t1 = time.perf_counter()
    obj_isam = float(graph.error(est))
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(1e-10)
    lm.setAbsoluteErrorTol(1e-12)
    lm.setMaxIterations(lm_iterations)
    values = gtsam.LevenbergMarquardtOptimizer(graph, est, lm).optimize()
    t2 = time.perf_counter()
    poses = np.array([[p.x(), p.y(), p.theta()]
                      for p in (values.atPose2(X(int(i))) for i in ids)]).reshape(-1, 3)
    lids = np.array(sorted(seen), dtype=np.int64)
    lms = np.array([values.atPoint2(L(int(j))) for j in lids], dtype=float).reshape(-1, 2)
    return RecordedReference(poses, lids, lms, float(graph.error(values)), obj_isam,
                             t1 - t0, t2 - t1, t2 - t0)


# --------------------------------------------------------------------------- scoring

def score_filter(result: SlamResult, ref: RecordedReference) -> dict[str, Any]:
    """One filter against the smoother (keys that do not apply are left out)."""
    out: dict[str, Any] = {"time_s": result.time_s, "diverged": result.diverged,
                           "landmarks_mapped": int(len(result.landmark_ids))}
    if result.failure:
        out["failure"] = result.failure
    pos = {int(j): i for i, j in enumerate(ref.landmark_ids)}
    common = [(i, pos[int(j)]) for i, j in enumerate(result.landmark_ids) if int(j) in pos]
    if common:
        a, b = np.array(common).T
        A, B = result.landmarks[a], ref.landmarks[b]
        d = np.linalg.norm(A - B, axis=1)
        if np.all(np.isfinite(d)):
            out["landmark_dist_to_ref_median_m"] = float(np.median(d))
            out["landmark_dist_to_ref_max_m"] = float(np.max(d))
            if len(d) >= 2:
                rot, d_aligned = _rigid_fit(A, B)
                out["map_rotation_to_ref_deg"] = rot
                out["landmark_dist_to_ref_aligned_median_m"] = float(np.median(d_aligned))
                out["landmark_dist_to_ref_aligned_max_m"] = float(np.max(d_aligned))
    last = result.poses[-1]
    if np.all(np.isfinite(last)):
        end = ref.poses[int(result.steps[-1])]
        out["final_pose_dist_to_ref_m"] = float(np.hypot(*(last[:2] - end[:2])))
        out["final_heading_diff_to_ref_deg"] = float(np.degrees(abs(wrap_angle(last[2]
                                                                               - end[2]))))
    ok = np.all(np.isfinite(result.poses), axis=1)
    if ok.any():
        e = result.poses[ok, :2] - ref.poses[result.steps[ok], :2]
        out["pose_rmse_to_ref_m"] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    if result.time_s > 0:
        out["isam2_time_over_filter_time"] = ref.time_isam2_s / result.time_s
    return out


def _rigid_fit(A: Array, B: Array) -> tuple[float, Array]:
    """Best rotation + translation of points ``A`` onto ``B`` (least squares): the
    rotation (deg) and the distances left after it.  Separates a map that is rotated as
    a whole (a filter's heading error) from one that is distorted."""
    ca, cb = A.mean(axis=0), B.mean(axis=0)
    H = (A - ca).T @ (B - cb)
    ang = math.atan2(H[0, 1] - H[1, 0], H[0, 0] + H[1, 1])
    c, s = math.cos(ang), math.sin(ang)
    R = np.array([[c, -s], [s, c]])
    return math.degrees(ang), np.linalg.norm((A - ca) @ R.T + cb - B, axis=1)


def run_log(log: OdometryLog, filters: tuple[str, ...] | list[str] = DEFAULT_FILTERS, *,
            mode: str = "local", max_epoch_steps: int = DEFAULT_MAX_EPOCH_STEPS,
            progress=None) -> dict[str, Any]:
    """Run the filters and the smoother on ``log``; the ``summary.json`` dict."""
    results = {}
    for name in filters:
        results[name] = run_recorded(log, name, mode=mode, max_epoch_steps=max_epoch_steps)
        if progress:
            progress(1)
    ref = smooth_recorded(log)
    if progress:
        progress(1)
    odo = dead_reckoning_poses(log)
    return {
        "log": Path(log.source).name,
        "source": log.source,
        "mode": mode,
        "poses": log.n_poses,
        "landmarks": int(len(log.landmark_ids)),
        "observations": int(len(log.obs_id)),
        "filters": {n: score_filter(r, ref) for n, r in results.items()},
        "baselines": {"odometry": {
            "final_pose_dist_to_ref_m": float(np.hypot(*(odo[-1, :2] - ref.poses[-1, :2]))),
            "pose_rmse_to_ref_m": float(np.sqrt(np.mean(np.sum((odo[:, :2]
                                                                - ref.poses[:, :2])**2, 1)))),
        }},
        "reference": {"gtsam": {
            "method": "iSAM2 pose by pose, then Levenberg-Marquardt",
            "objective_isam2": ref.objective_isam2,
            "objective": ref.objective,
            "time_isam2_s": ref.time_isam2_s,
            "time_lm_s": ref.time_lm_s,
            "time_s": ref.time_s,
        }},
    }


LOG_COLUMNS = ("estimator", "lm dist median (m)", "lm dist max (m)", "aligned median (m)",
               "map rotation (deg)", "final pose dist (m)", "time (s)", "iSAM2 time / time",
               "diverged")


def log_table(summary: dict[str, Any]) -> str:
    """The plain-text results table of a recorded-log run (distances are to the smoother;
    "aligned" after the best rigid rotation + translation of the filter's map)."""
    from .report import plain_table

    def num(v: Any, fmt: str) -> str:
        return "—" if v is None else format(v, fmt)

    rows = []
    for name, e in summary["filters"].items():
        rows.append([name, num(e.get("landmark_dist_to_ref_median_m"), ".3f"),
                     num(e.get("landmark_dist_to_ref_max_m"), ".3f"),
                     num(e.get("landmark_dist_to_ref_aligned_median_m"), ".3f"),
                     num(e.get("map_rotation_to_ref_deg"), "+.2f"),
                     num(e.get("final_pose_dist_to_ref_m"), ".3f"), num(e.get("time_s"), ".2f"),
                     num(e.get("isam2_time_over_filter_time"), ".1f"),
                     "yes" if e.get("diverged") else "no"])
    o = summary["baselines"]["odometry"]
    rows.append(["odometry", "—", "—", "—", "—", num(o["final_pose_dist_to_ref_m"], ".3f"), "—",
                 "—", "—"])
    g = summary["reference"]["gtsam"]
    rows.append(["gtsam", "0", "0", "0", "0", "0", num(g["time_s"], ".2f"), "—", "—"])
    head = (f"{summary['log']}: {summary['poses']} poses, {summary['landmarks']} landmarks, "
            f"{summary['observations']} observations, mode {summary['mode']}; smoother "
            f"½χ² {g['objective_isam2']:.1f} (iSAM2) -> {g['objective']:.1f} (+LM), "
            f"iSAM2 {g['time_isam2_s']:.1f} s + LM {g['time_lm_s']:.1f} s")
    return head + "\n\n" + plain_table(LOG_COLUMNS, rows)
