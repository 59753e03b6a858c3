r"""One run on an IMU + GNSS log: alignment, the INS filters, the GTSAM smoother, scores.

The fixes are split once (:func:`fix_roles`) into used, withheld (``--holdout``) and
dropped (``--outage``); every estimator sees exactly the used ones.  Each estimator's
position at every fix epoch (the prediction where the fix is not used) and its covariance
are kept as an :class:`EstimatorTrack`; :mod:`slam.kinds.ins_log.scoring` turns them into
the scores.  CPU time is ``time.process_time`` around each estimator's whole run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators.loop import BeliefRecorder, run_epochs
from estimators.models import Belief
from nav.alignment import level, track_heading
from nav.euler import euler_zyx_to_q
from nav.gnss import gnss_measurement
from nav.gravity import gravity_vector
from nav.ins import (
    LAYOUT,
    SPACE,
    InsModel,
    Preintegrated,
    epoch_biases,
    ins_transition,
    pad_epochs,
    preintegrate_stack,
    preintegrates,
)
from nav.quaternion import qto_dcm
from nav.strapdown import dcm_unit, earth_rate_enu
from slam.kinds.ins_log import invariant
from slam.kinds.ins_log.log import InsLog
from slam.kinds.ins_log.world import SCORE_FROM, InsLogWorld, Scoring
from slam.results import REFERENCE, RunOutcome

Array = NDArray[np.float64]
ONLINE = "gtsam-online"
SMOOTHED = REFERENCE
USED, WITHHELD, DROPPED = 0, 1, 2
POSE = np.r_[0:3, 6:9]
"""The tangent rows of ``[δp, δθ]`` in the 15-state error ``[δp, δv, δθ, δb_g, δb_a]``."""


@dataclass(frozen=True)
class EstimatorTrack:
    """An estimator's IMU position ``p`` (E, 3) and covariance ``P`` (E, 3, 3) at the fix epochs
    ``a .. F-1`` (the alignment fix first), its NIS per update with the update's fix,
    its CPU seconds and its failure (``None``)."""

    name: str
    p: Array
    P: Array
    nis: Array
    nis_fix: NDArray[np.int64]
    nis_dof: int
    cpu_s: float
    failure: str | None = None
    p_fix: Array | None = None
    """The position the fixes measure (the antenna at the lever arm; ``p`` without one)."""
    q: Array | None = None
    """The attitude ``q_nb`` (E, 4), scalar first, at the same epochs (for the TUM files)."""
    pose_cov: Array | None = None
    """The covariance (E, 6, 6) of ``[δp (m, navigation frame), δθ (rad, body frame:
    q = q̂ ⊗ Exp(δθ))]`` (NaN where the estimator gives none)."""

    @property
    def at_fix(self) -> Array:
        return self.p if self.p_fix is None else self.p_fix


@dataclass(frozen=True)
class LogScores:
    """One estimator's entry: its group in the summary and its values."""

    name: str
    group: str
    values: dict[str, Any]
    diverged: bool = False
    failure: str | None = None


def fix_roles(log: InsLog, scoring: Scoring) -> NDArray[np.int64]:
    """Per fix: :data:`USED`, :data:`WITHHELD` (every ``holdout``-th) or :data:`DROPPED`
    (inside an outage window, from the first IMU stamp)."""
    roles = np.full(log.n_fixes, USED, dtype=np.int64)
    if scoring.holdout:
        idx = np.arange(log.n_fixes)
        roles[(idx % scoring.holdout == 0) & (idx > 0)] = WITHHELD
    rel = log.fix_t - log.t[0]
    for start, length in scoring.outages:
        roles[(rel >= start) & (rel < start + length)] = DROPPED
    return roles


def alignment(log: InsLog, roles: Array) -> tuple[int, Array, Array, str]:
    """The first fix ``a`` used, with the previous one used, at ``min_speed_mps`` or more
    from it; ``(a, x0, P0, how)`` (:mod:`nav.alignment`)."""
    s = log.settings
    P = log.fix_p
    for a in range(1, log.n_fixes):
        if roles[a] != USED or roles[a - 1] != USED:
            continue
        dt = log.fix_t[a] - log.fix_t[a - 1]
        d = P[a] - P[a - 1]
        if math.hypot(d[0], d[1]) / dt >= s.min_speed_mps:
            break
    else:
        raise ValueError(f"no two consecutive used fixes {s.min_speed_mps:g} m/s apart: the "
                         "heading cannot be aligned from the GNSS track")
    g, f, h = log.epochs.of(a)
    f_mean = (f * h[:, None]).sum(axis=0) / h.sum()
    roll, pitch = level(f_mean)
    yaw = track_heading(P[a - 1], P[a])
    v0 = log.fix_v[a] if log.fix_v is not None else d / dt
    q0 = euler_zyx_to_q(roll, pitch, yaw)
    p0 = P[a] - qto_dcm(q0) @ np.asarray(s.lever_arm_m, dtype=float)  # the IMU, not the antenna
    x0 = np.concatenate([p0, v0, q0, np.zeros(6)])
    sp = log.fix_sp[a] if log.fix_sp is not None else np.full(3, s.position_sigma_m)
    sig = np.concatenate([sp, np.full(3, s.velocity0_sigma_mps),
                          [s.roll_pitch_sigma_rad] * 2, [s.heading_sigma_rad],
                          np.full(3, s.gyro_bias0_sigma), np.full(3, s.accel_bias0_sigma)])
    how = (f"aligned at fix {a} (t = {log.fix_t[a] - log.t[0]:.2f} s): roll "
           f"{math.degrees(roll):+.2f} deg, pitch {math.degrees(pitch):+.2f} deg from the mean "
           f"specific force since fix {a - 1}, heading {math.degrees(yaw):+.2f} deg from the "
           "GNSS track")
    return a, x0, np.diag(sig**2), how


def model_of(log: InsLog) -> InsModel:
    s = log.settings
    er = earth_rate_enu(s.latitude_rad) if s.earth_rate else None
    return InsModel(s.psd, gravity_vector(s.latitude_rad, s.height_m), er)


def measurement_of(log: InsLog, i: int, cache: dict | None = None) -> tuple[Any, Array]:
    """Fix ``i``'s GNSS measurement and its value (``cache``: the models built so far,
    by their σ)."""
    s = log.settings
    arm = s.lever_arm_m if any(s.lever_arm_m) else None
    sp = None if log.fix_sp is None else log.fix_sp[i]
    sv = None if log.fix_sv is None else log.fix_sv[i]
    if sv is not None and arm is not None:
        raise ValueError("a GNSS velocity with a lever arm is not supported on a log")
    key = (None if sp is None else tuple(sp), None if sv is None else tuple(sv))
    meas = None if cache is None else cache.get(key)
    if meas is None:
        meas = gnss_measurement(LAYOUT, position_sigma=sp, velocity_sigma=sv, lever_arm=arm)
        if cache is not None:
            cache[key] = meas
    z = np.concatenate([v[i] for v in (log.fix_p, log.fix_v) if v is not None])
    return meas, z


def uses_preintegration(model: InsModel) -> bool:
    """The prediction is preintegrated (:func:`nav.ins.preintegrates` with
    :func:`nav.ins.ins_transition`'s default, which ``benchmarks.kitti_speed`` switches)."""
    return preintegrates(model, bool(ins_transition.__kwdefaults__["preintegrated"]))


class Ahead:
    """The increments of ``fixes`` epochs at a time (:func:`nav.ins.preintegrate_stack`), about
    the biases of the mean at the first of them; ``fixes = 1``: none (each epoch is
    preintegrated about its own mean's biases by :func:`nav.ins.ins_transition`)."""

    def __init__(self, log: InsLog, model: InsModel, fixes: int):
        self.log, self.model, self.fixes = log, model, int(fixes)
        self.done: dict[int, Preintegrated | None] = {}

    def of(self, i: int, mean: Array) -> Preintegrated | None:
        """Epoch ``i``'s increments (``None`` with ``fixes = 1`` or for an epoch of no
        samples, which :func:`~nav.ins.ins_transition` then handles as before), computing
        the next batch from ``mean`` when ``i`` is not in the last."""
        if self.fixes <= 1:
            return None
        if i not in self.done:
            stop = min(i + self.fixes, self.log.n_fixes)
            self.done = dict.fromkeys(range(i, stop))
            pieces = {k: p for k in range(i, stop) if len((p := self.log.epochs.of(k))[2])}
            if not pieces:
                return None
            g, f, h, counts = pad_epochs(list(pieces.values()))
            b = np.array([epoch_biases(mean, float(np.sum(p[2])), self.model)
                          for p in pieces.values()])
            self.done.update(zip(pieces, preintegrate_stack(g, f, h, b, counts)))
        return self.done[i]


def run_filter(world: InsLogWorld, name: str, a: int, x0: Array, P0: Array, roles: Array
               ) -> EstimatorTrack:
    """INS filter ``name`` from the alignment fix ``a`` (module docstring); the prior
    already holds fix ``a`` (its position and σ), so the first update is at the next.
    An invariant variant (``<filter>-inv``) runs in the group error
    (:mod:`slam.kinds.ins_log.invariant`)."""
    log = world.log
    c0 = time.process_time()
    flt = world.filters.make(name)
    model = model_of(log)
    E = log.n_fixes - a
    rec = BeliefRecorder.empty(E, 16, 15)
    models: dict = {}
    inv = invariant.is_invariant(name)

    ahead = Ahead(log, model, log.settings.preintegration_fixes
                  if uses_preintegration(model) else 1)

    def transition(e: int, b: Belief):
        g, f, h = log.epochs.of(a + e)
        t = ins_transition(b.mean, g, f, h, model, pre=ahead.of(a + e, b.mean))
        return (invariant.group_transition(t, b.mean) if inv else t), None

    def correct(e: int, b: Belief):
        i = a + e
        if roles[i] != USED:
            return b, []
        meas, z = measurement_of(log, i, models)
        post, inn = flt.update(b, meas, z)
        return post, [inn]

    try:
        prior = (flt.init(x0, invariant.GROUP, sqrt=invariant.group_prior(x0, P0)) if inv
                 else flt.init(x0, SPACE, cov=P0))
        out = run_epochs(flt, prior, E, transition=transition,
                         correct=correct, record=rec, correct_first=False)
        failure = out.failure
        nis, nis_fix = np.asarray(out.nis), np.asarray(out.nis_epoch, dtype=np.int64) + a
    except ValueError as exc:  # a model the filter refuses (e.g. a non-finite covariance)
        failure, nis, nis_fix = f"ValueError: {exc}", np.zeros(0), np.zeros(0, np.int64)
    dof = 3 * sum(v is not None for v in (log.fix_p, log.fix_v))
    cpu = time.process_time() - c0
    arm = np.asarray(log.settings.lever_arm_m, dtype=float)
    p_fix = None
    if np.any(arm):
        with np.errstate(invalid="ignore"):
            p_fix = rec.means[:, :3] + dcm_unit(rec.means[:, 6:10]) @ arm
    covs = invariant.world_covariances(rec.means, rec.covs) if inv else rec.covs
    return EstimatorTrack(name, rec.means[:, :3], covs[:, :3, :3], nis, nis_fix, dof, cpu,
                          failure, p_fix, rec.means[:, 6:10], covs[:, POSE][:, :, POSE])


def run_once(world: InsLogWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False,
             reference: bool = True) -> RunOutcome:
    """The filters and the smoother on the log (the seed is unused: a log is one run)."""
    from slam.kinds.ins_log.reference import smooth
    from slam.kinds.ins_log.scoring import score_track

    log = world.log
    roles = fix_roles(log, world.scoring)
    a, x0, P0, how = alignment(log, roles)
    tracks: dict[str, EstimatorTrack] = {n: run_filter(world, n, a, x0, P0, roles)
                                         for n in filters}
    if reference:
        tracks.update(smooth(log, a, x0, P0, roles))
    scores = {}
    for n, tr in tracks.items():
        group = "filters" if n in filters else "reference"
        values = score_track(log, tr, a, roles, world.scoring)
        values["alignment"] = how
        scores[n] = LogScores(n, group, values, tr.failure is not None, tr.failure)
    return RunOutcome(run, scores, tracks if keep_tracks else {},  # type: ignore[arg-type]
                      times=log.fix_t[a:] - log.t[0])


def summarize(world: InsLogWorld, outcomes: list[RunOutcome], filters: list[str],
              runs: int, seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a log run."""
    from slam.kinds.ins_log.scoring import summary_of

    return summary_of(world, outcomes[0], filters, SCORE_FROM)
