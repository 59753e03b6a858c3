"""Result values passed from the Monte Carlo runs to scoring and reports.

A worker reduces each estimator's output on one run to a :class:`RunScores`
(errors and standard deviations per step, NEES, landmark errors, NIS, timing) so
that little crosses process boundaries; run 0 also keeps full :class:`Track`\\ s for
the plots and trajectory files.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

ODOMETRY = "odometry"
REFERENCE = "gtsam"


@dataclass(frozen=True)
class Track:
    """One estimator's full output on one run (kept for run 0 only).

    poses : (K + 1, 3) ``[x, y, φ]`` per step; pose_cov : (K + 1, 3, 3), NaN where the
    estimator gives none (the smoother between its epochs); landmark_ids (L,),
    landmarks (L, 2), landmark_cov (L, 2, 2).
    """

    name: str
    poses: Array
    pose_cov: Array
    landmark_ids: NDArray[np.int64]
    landmarks: Array
    landmark_cov: Array


@dataclass(frozen=True)
class PoseTrack:
    """One estimator's poses on one run, kept for its TUM file (:mod:`slam.render.tum`):
    times (E,) s; p (E, 3) position, or ``None`` for an attitude-only estimator (zero
    position in the file); q (E, 4) ``q_wxyz``; cov (E, k, k) the pose covariance in the
    kind's stated tangent, or ``None``; rows with a non-finite pose are left out."""

    times: Array
    p: Array | None
    q: Array
    cov: Array | None


@dataclass(frozen=True, kw_only=True)
class EstimatorRun:
    """What every estimator's result on one run carries besides its errors (the base of
    the kinds' per-run scores; keyword-only, after each kind's own fields).

    nis : per update (NaN where none) and nis_dof : the dof of each update (an array) or
    of every update (an int); time_s : wall time; diverged : bool; failure : reason;
    extra_time_s : time outside ``time_s`` (the smoother's marginals).
    """

    nis: Array
    nis_dof: int | NDArray[np.int64]
    time_s: float
    diverged: bool = False
    failure: str | None = None
    extra_time_s: float = 0.0


@dataclass(frozen=True, kw_only=True)
class SlamRun(EstimatorRun):
    """The :class:`EstimatorRun` fields of a SLAM kind's (planar, drone) estimator and
    what it adds to them: steps : filter epochs processed (predict + update cycles); per
    batch update nis, nis_dof and nis_epoch : (U,) its epoch index (``None``: not
    recorded); map_series : the filter's map per epoch
    (:class:`~slam.mapping.map_series.MapSeries`; ``None`` for estimators without one).
    """

    steps: int
    nis_epoch: NDArray[np.int64] | None = None
    map_series: Any = None


@dataclass(frozen=True, kw_only=True)
class SlamRunScores(SlamRun):
    """The :class:`SlamRun` fields and what the SLAM kinds' scores add to them:
    err_track : (E, 2) ``[along-track, cross-track]`` position error (m) in the frame of
    the true direction of travel (cross-track positive to the left), sig_track : (E, 2)
    own σ (both single precision: they only feed figures).
    """

    err_track: Array | None = None
    sig_track: Array | None = None


@dataclass(frozen=True)
class RunScores(SlamRunScores):
    """One estimator on one run, reduced (and the :class:`SlamRunScores` fields).

    err : (E, 3) at the filter epochs: estimate minus truth ``[ex, ey, eφ]`` (m, m, rad; φ wrapped).
    sigma : (E, 3) the estimator's own standard deviations (NaN where none).

    nees : (E,) vehicle-pose NEES (3 dof), NaN where the covariance is singular
        or absent.

    lm_err : (L,) final landmark position errors (m).
    """

    name: str
    err: Array
    sigma: Array
    nees: Array
    lm_err: Array


@dataclass(frozen=True)
class RunOutcome:
    """Everything one Monte Carlo run returns: scores per estimator (and tracks), and
    ``events``: epoch indices of named events of the run (the planar kind's loop closure,
    :mod:`slam.kinds.planar.segments`)."""

    run: int
    scores: dict[str, RunScores]
    tracks: dict[str, Track] = field(default_factory=dict)
    truth: Array | None = None
    true_landmarks: Array | None = None
    times: Array | None = None
    events: dict[str, int] = field(default_factory=dict, kw_only=True)


@dataclass(frozen=True)
class CampaignResult:
    """A whole campaign: the world's identity, the runs, and the summary dict.

    ``summary`` follows the ``summary.json`` contract (see DESIGN / README): no null
    without its reason beside it (:mod:`slam.nulls`);
    ``outcomes`` keeps every run's :class:`RunScores` for plots (errors vs time).
    """

    world: Any
    summary: dict[str, Any]
    outcomes: list[RunOutcome]


@dataclass(frozen=True)
class EstimateSeries(EstimatorRun):
    """One attitude estimator's output at the update epochs (star sensor, vector
    observations): means : (M, 7) ``[q, b]``; covs : (M, 6, 6) tangent covariances (NaN
    where none); cycles : predict + update pairs.  The :class:`EstimatorRun` fields:
    nis : (M,) per update (NaN for the smoother); time_s : wall time of the ``cycles``
    (filters) or of the solve (smoother).
    """

    name: str
    means: Array
    covs: Array
    cycles: int
