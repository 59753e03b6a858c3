r"""The attitude filters and the GTSAM AHRS smoother on a recorded attitude log, scored
against its truth and against the smoother.

State ``[q_nb, b]`` on ``Product([UnitQuaternion(), Euclidean(3)])`` (the star-sensor
kind's, :mod:`slam.kinds.attitude.filtering`).  Epochs: the first row, every row with a
direction reading, the last row.  Between two epochs the rows' gyro readings drive
:math:`q' = q \otimes \prod_k \mathrm{Exp}((\tilde\omega_k - b)\,\Delta t_k)` with each row's
own :math:`\Delta t_k = t_k - t_{k-1}` and the interval noise of
:func:`nav.gyro.interval_noise` over :math:`T = \sum_k \Delta t_k`; at an epoch the
readings of the sensors that read are one update of :func:`nav.observations.direction_measurement`
(body-frame readings :math:`C(q)^\top d_i`, the file's σ).  Every estimator starts from
the same belief (:data:`~slam.kinds.attitude_log.world.INITIAL_ATTITUDE_VAR_RAD2`).

The smoother: ``Rot3`` and bias states at the epochs, ``AHRSFactor`` over each interval's
rows (``PreintegratedAhrsMeasurements``, gyro covariance from ``std_w``), a bias random
walk ``BetweenFactorVector`` (σ_b √T), ``AttitudeFactorRot3`` per reading (its unit
direction in the navigation frame against the body-frame reading, σ the reading's),
priors equal to the filters' initial belief; Levenberg-Marquardt from dead reckoning.

Errors are body-frame :math:`\mathrm{Log}(\hat q^* \otimes q)` and :math:`b - \hat b` at the
epochs; NEES is of the 6-dof error.  The NIS counts 2 dof per reading: a unit reading's
radial component carries no noise, so its 3 × 3 innovation covariance over-states that
direction and the radial term adds nothing to first order.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import Transition
from estimators.loop import run_epochs
from estimators.models import Noise
from estimators.threads import single_thread_blas
from nav.gyro import interval_noise, propagate_points
from nav.observations import direction_measurement
from nav.quaternion import dcm_to_q
from slam.failures import run_reference
from slam.kinds.attitude.filtering import QUAT, STATE
from slam.kinds.attitude.run import AttitudeTrack
from slam.kinds.attitude_log.log import AttitudeRecord
from slam.kinds.attitude_log.world import AttitudeLogWorld
from slam.results import REFERENCE, Array, RunOutcome
from slam.scoring import nees_series

STEADY_FROM_S = 10.0
"""Statistics marked ``after_10s`` leave out the first 10 s (the filters converging)."""
DEG = math.pi / 180.0


@dataclass(frozen=True)
class Series:
    """One estimator's output at the epochs: means (E, 7) ``[q, b]``, covs (E, 6, 6) (NaN
    where none), per update nis / nis_dof / nis_epoch, wall and CPU time."""

    name: str
    means: Array
    covs: Array
    nis: Array
    nis_dof: Array
    nis_epoch: Array
    time_s: float
    cpu_s: float
    diverged: bool = False
    failure: str | None = None
    extra_time_s: float = 0.0


@functools.lru_cache(maxsize=256)
def _transition(dts: tuple[float, ...], arw: tuple[float, ...], bias_rw: tuple[float, ...]
                ) -> Transition:
    """The interval of rows spaced ``dts`` (module docstring)."""
    dt = np.asarray(dts)[:, None]
    Q = interval_noise(float(np.sum(dts)), np.asarray(arw), np.asarray(bias_rw))
    return Transition(lambda X, u: propagate_points(X, np.asarray(u, dtype=float), dt),
                      Noise.from_cov(Q + 1e-30 * np.eye(6)), additive=True)


def _interval(log: AttitudeRecord, a: int, b: int) -> tuple[Transition, Array]:
    """Model and gyro rows from epoch row ``a`` to row ``b`` (rows a+1 .. b)."""
    dts = tuple(np.round(np.diff(log.t[a:b + 1]), 15).tolist())
    return _transition(dts, tuple(log.arw), tuple(log.bias_rw)), log.gyro[a + 1:b + 1]


def _readings(log: AttitudeRecord, k: int) -> tuple[Any, Array, int] | None:
    seen = log.seen[k]
    if not seen.any():
        return None
    return (direction_measurement(log.refs[k][seen], log.sigma[k][seen]),
            log.body[k][seen].ravel(), int(seen.sum()))


def run_filter(world: AttitudeLogWorld, name: str) -> Series:
    """Filter ``name`` (with the stated settings) over the log's epochs."""
    log, fs = world.log, world.filters
    rows = log.epochs
    E = len(rows)
    flt = fs.make(name)
    x0, P0 = fs.initial()
    means, covs = np.full((E, 7), np.nan), np.full((E, 6, 6), np.nan)
    readings: list[int] = []

    def record(e: int, b) -> None:
        means[e], covs[e] = b.mean, b.cov

    def correct(e: int, b):
        got = _readings(log, int(rows[e]))
        if got is None:
            return b, []
        meas, z, n = got
        b, inn = flt.update(b, meas, z)
        readings.append(n)
        return b, [inn]

    cpu0 = time.process_time()
    with single_thread_blas():
        out = run_epochs(flt, flt.init(x0, STATE, cov=P0), E, correct_first=True,
                         record=record, correct=correct,
                         transition=lambda e, b: _interval(log, int(rows[e - 1]), int(rows[e])))
    cpu = time.process_time() - cpu0
    dof = 2.0 * np.asarray(readings[:len(out.nis)], dtype=float)
    return Series(name, means, covs, np.asarray(out.nis, dtype=float), dof,
                  np.asarray(out.nis_epoch, dtype=np.int64), out.time_s, cpu,
                  out.failure is not None, out.failure)


def smooth(world: AttitudeLogWorld, marginals: bool = True) -> Series:
    """The GTSAM AHRS smoother on the log (module docstring)."""
    import gtsam

    log = world.log
    x0, P0 = world.filters.initial()
    rows = log.epochs
    E = len(rows)
    t0, cpu0 = time.perf_counter(), time.process_time()
    X = [gtsam.symbol("x", j) for j in range(E)]
    B = [gtsam.symbol("b", j) for j in range(E)]
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    params = gtsam.PreintegratedRotationParams()
    params.setGyroscopeCovariance(np.diag(log.arw**2))
    graph.add(gtsam.PriorFactorRot3(X[0], gtsam.Rot3(), gtsam.noiseModel.Isotropic.Sigma(
        3, math.sqrt(P0[0, 0]))))
    graph.add(gtsam.PriorFactorVector(B[0], np.zeros(3), gtsam.noiseModel.Isotropic.Sigma(
        3, math.sqrt(P0[3, 3]))))
    zero3 = np.zeros(3)
    blocks = []
    for j in range(E):
        k = int(rows[j])
        for s in np.flatnonzero(log.seen[k]):
            noise = gtsam.noiseModel.Isotropic.Sigma(2, float(np.mean(log.sigma[k, s])))
            graph.add(gtsam.AttitudeFactorRot3(X[j], gtsam.Unit3(log.refs[k, s]), noise,
                                               gtsam.Unit3(log.body[k, s])))
        if j + 1 < E:
            a, b = k, int(rows[j + 1])
            pim = gtsam.PreintegratedAhrsMeasurements(params, zero3)
            for w, dt in zip(log.gyro[a + 1:b + 1], np.diff(log.t[a:b + 1])):
                pim.integrateMeasurement(w, float(dt))
            graph.add(gtsam.AHRSFactor(X[j], X[j + 1], B[j], pim))
            T = float(log.t[b] - log.t[a])
            graph.add(gtsam.BetweenFactorVector(B[j], B[j + 1], zero3,
                                                gtsam.noiseModel.Diagonal.Sigmas(
                                                    log.bias_rw * math.sqrt(T))))
            blocks.append((log.gyro[a + 1:b + 1], np.diff(log.t[a:b + 1])))
    guess = [np.asarray(x0, dtype=float)]
    for w, dt in blocks:  # dead reckoning with zero bias, as the filters propagate
        guess.append(propagate_points(guess[-1][None], w, dt[:, None])[0])
    for j in range(E):
        values.insert(X[j], gtsam.Rot3.Quaternion(*map(float, guess[j][:4])))
        values.insert(B[j], zero3)
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(1e-7)
    lm.setAbsoluteErrorTol(1e-9)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values, lm).optimize()
    means = np.empty((E, 7))
    means[:, :4] = dcm_to_q(np.array([result.atRot3(k).matrix() for k in X]))
    means[:, 4:] = np.array([result.atVector(k) for k in B])
    solve_s, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    covs = np.full((E, 6, 6), np.nan)
    t1 = time.perf_counter()
    if marginals:
        marg = gtsam.Marginals(graph, result)
        for j in range(E):
            jm = marg.jointMarginalCovariance([X[j], B[j]])
            covs[j] = np.block([[jm.at(X[j], X[j]), jm.at(X[j], B[j])],
                                [jm.at(B[j], X[j]), jm.at(B[j], B[j])]])
    return Series(REFERENCE, means, covs, np.zeros(0), np.zeros(0), np.zeros(0, np.int64),
                  solve_s, cpu, extra_time_s=time.perf_counter() - t1)


@dataclass(frozen=True)
class AttitudeLogScores:
    """One estimator on the log: err (E, 6) ``[Log(q̂* ⊗ q), b - b̂]`` (rad, rad/s), sigma
    (E, 6) its own σ, nees (E,), err_to_ref (E, 3) attitude against the smoother, and
    the :class:`Series` timing, NIS and failure."""

    name: str
    err: Array
    sigma: Array
    nees: Array
    err_to_ref: Array
    nis: Array
    nis_dof: Array
    nis_epoch: Array
    time_s: float
    cpu_s: float
    diverged: bool
    failure: str | None
    extra_time_s: float = 0.0


def score(s: Series, log: AttitudeLogWorld, ref: Series | None) -> AttitudeLogScores:
    """Errors of ``s`` against the truth (and the smoother ``ref``) at the epochs."""
    rows = log.log.epochs
    q_true, b_true = log.log.truth_q[rows], log.log.truth_bias[rows]
    ok = np.all(np.isfinite(s.means), axis=1)
    err = np.full((len(rows), 6), np.nan)
    err[ok, :3] = QUAT.local(s.means[ok, :4], q_true[ok])
    err[:, 3:] = b_true - s.means[:, 4:]
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.diagonal(s.covs, axis1=1, axis2=2))
    to_ref = np.full((len(rows), 3), np.nan)
    if ref is not None and s.name != REFERENCE:
        both = ok & np.all(np.isfinite(ref.means), axis=1)
        to_ref[both] = QUAT.local(s.means[both, :4], ref.means[both, :4])
    return AttitudeLogScores(s.name, err, sigma, nees_series(err, s.covs), to_ref, s.nis,
                             s.nis_dof, s.nis_epoch, s.time_s, s.cpu_s, s.diverged, s.failure,
                             s.extra_time_s)


def run_once(world: AttitudeLogWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False) -> RunOutcome:
    """Every filter and the smoother on the log (the seed is unused).  With ``keep_tracks``
    the tracks are :class:`~slam.kinds.attitude.run.AttitudeTrack`, ``truth`` (E, 7) and
    ``times`` the epochs' time stamps."""
    series = [run_filter(world, n) for n in filters]
    ref, failure = run_reference(smooth, world)
    E = len(world.log.epochs)
    if ref is None:
        ref = Series(REFERENCE, np.full((E, 7), np.nan), np.full((E, 6, 6), np.nan),
                     np.zeros(0), np.zeros(0), np.zeros(0, np.int64), 0.0, 0.0, True, failure)
    series.append(ref)
    good_ref = None if ref.diverged else ref
    scores = {s.name: score(s, world, good_ref) for s in series}
    if not keep_tracks:
        return RunOutcome(run, scores)  # type: ignore[arg-type]
    rows = world.log.epochs
    tracks = {s.name: AttitudeTrack(s.name, s.means[:, :4], s.means[:, 4:], s.covs)
              for s in series}
    truth = np.hstack([world.log.truth_q[rows], world.log.truth_bias[rows]])
    return RunOutcome(run, scores, tracks, truth, None, world.log.t[rows])  # type: ignore
