r"""Star-sensor attitude scenario ([Wang SRCKF-SLAM] §5.1-5.2): filters, GTSAM smoother, scores.

State and models
----------------
The state is ``[q_nb, b]`` on ``Product([UnitQuaternion(), Euclidean(3)])`` (ambient 7,
tangent 6): attitude error :math:`q = \hat q \otimes \mathrm{Exp}(\delta\theta)` (body frame,
right perturbation, as GTSAM's ``Rot3.retract``), bias error :math:`b = \hat b + \delta b`.

* **Time update, one per star interval.**  :func:`nav.gyro.interval_transition` builds one
  :class:`~estimators.Transition` whose ``f(X, u)`` carries every sigma point (rows of
  ``X``) through the ``n`` gyro samples ``u`` of the interval at once:
  :math:`q' = q \otimes \prod_k \mathrm{Exp}((\tilde\omega_k - b)\,dt)`, :math:`b' = b`.
  The ``n`` increments of all points come from one batched ``qexp``; their ordered
  product is a pairwise (tree) reduction, ``⌈log2 n⌉`` batched ``qmul`` calls.
* **Process noise, additive in the tangent at the end of the interval.**  With the
  error dynamics :math:`\dot{\delta\theta} = -[\hat\omega\times]\delta\theta - \delta b - n_g`,
  :math:`\dot{\delta b} = n_b` (densities :math:`\sigma_g^2`, :math:`\sigma_b^2`) the
  interval :math:`T = n\,dt` adds

  .. math::

      Q = \begin{bmatrix} (\sigma_g^2 T + \sigma_b^2 T^3/3) I & -\sigma_b^2 T^2/2\, I \\
          -\sigma_b^2 T^2/2\, I & \sigma_b^2 T\, I \end{bmatrix}.

  The rotation :math:`\mathrm{Exp}(-[\hat\omega\times] s)` that carries noise injected at
  time :math:`T - s` to the end of the interval leaves the (isotropic) angle-random-walk
  and bias blocks unchanged; it is neglected in the bias-driven attitude terms, an
  :math:`O(|\omega| T)` (0.15 % here) change of terms that are ~3e-9 of the diagonal.
  The simulation's per-sample angle random walk sums to exactly :math:`\sigma_g^2 T`.
* **Star update.**  Quaternion mode: ``h(X) = q`` on the ``UnitQuaternion`` measurement
  space, innovation :math:`\mathrm{Log}(\hat z^* \otimes z)`, :math:`R = \sigma^2 I_3`.  Vector
  mode: ``h(X)`` stacks :math:`C(q)^\top r_j` on :math:`\mathbb R^{3k}` with
  :math:`R = \sigma^2 I_{3k}` (the radial variance is not in the data, but the radial
  direction carries no information to first order, so it only lowers the NIS).
* ``srckf``/``srukf``/``srcdkf``/... come from :func:`estimators.make_filter`; ``ekf`` is
  the multiplicative EKF (MEKF): the core's EKF on this product space is an error-state
  filter that retracts by quaternion multiplication.  Its transition Jacobian is the
  core's central difference through the spaces; the measurement Jacobians are analytic
  (:math:`[I_3\ 0]` and :math:`[[C^\top r_j]_\times\ 0]`).

The smoother (:func:`~slam.kinds.attitude.smoother.smooth_attitude`) is GTSAM on the same
log (:mod:`slam.kinds.attitude.smoother`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators import Measurement, make_filter, wrap_angle
from nav.euler import euler_error_jacobian, euler_zxy_to_q, q_to_euler_zxy
from nav.gyro import interval_transition
from nav.observations import direction_measurement, quaternion_measurement
from slam.failures import run_reference
from slam.kinds.attitude.decision import decide_attitude
from slam.kinds.attitude.filtering import (  # noqa: F401  (re-exported)
    QUAT,
    STATE,
    batch_filter,
    run_filter,
    star_observation,
)
from slam.kinds.attitude.simulate import AttitudeLog, AttitudeSimConfig, simulate_attitude
from slam.kinds.attitude.smoother import smooth_attitude  # noqa: F401  (re-exported)
from slam.results import REFERENCE, EstimateSeries, EstimatorRun, RunOutcome
from slam.scoring import anees_stats, nees_series, per_epoch_anees, scored_runs, timing

Array = NDArray[np.float64]


AXES = ("roll", "pitch", "yaw")
ARCSEC = math.pi / 180.0 / 3600.0
DEG_H = math.pi / 180.0 / 3600.0
ARCMIN = 60.0 * ARCSEC
FILTER_DESCRIPTIONS = {
    "ekf": "MEKF: multiplicative (error-state) EKF, quaternion retracted by multiplication",
    "ckf": "cubature Kalman filter (dense covariance)",
    "ukf": "unscented Kalman filter (dense covariance)",
    "cdkf": "central-difference Kalman filter (dense covariance)",
    "srckf": "square-root cubature Kalman filter",
    "srukf": "square-root unscented Kalman filter",
    "srcdkf": "square-root central-difference Kalman filter",
    "svdckf": "cubature Kalman filter with an SVD-factored covariance",
}


# --------------------------------------------------------------------------- models

def sim_config(world) -> AttitudeSimConfig:
    """The simulation settings of an ``attitude`` world."""
    sat, gyro, star = world.satellite, world.gyro, world.star
    return AttitudeSimConfig(
        duration_s=world.duration_s,
        gyro_rate_hz=gyro.rate_hz,
        star_rate_hz=star.rate_hz,
        orbital_rate_rad_s=sat.orbital_rate_rad_s,
        initial_euler_rad=sat.initial_attitude_rad,
        body_rate_rad_s=sat.initial_rate_rad_s,
        gyro_bias_rad_s=gyro.bias_rad_s,
        gyro_bias_rw_rad_s_sqrt_s=gyro.bias_rw_rad_s_sqrt_s,
        gyro_arw_rad_sqrt_s=gyro.arw_rad_sqrt_s,
        star_sigma_rad=star.sigma_rad,
        star_mode=star.mode,
        star_directions=star.directions,
    )


def star_measurement(mode: str, sigma: float, refs: Array | None = None) -> Measurement:
    """The star update: a quaternion (``UnitQuaternion`` space) or stacked unit vectors
    (:mod:`nav.observations`)."""
    if mode == "quaternion":
        return quaternion_measurement(sigma)
    return direction_measurement(refs, sigma)


def initial_belief(world, log: AttitudeLog) -> tuple[Array, Array]:
    """``(x0, P0)``: truth's Z-X-Y Euler angles plus the world's error; zero bias."""
    fs = world.filters
    euler = q_to_euler_zxy(log.truth_q[0]) + np.asarray(fs.initial_error_rad)
    x0 = np.concatenate([euler_zxy_to_q(*euler), np.zeros(3)])
    P0 = np.diag([fs.initial_attitude_var_rad2] * 3 + [fs.initial_bias_var_rad2_s2] * 3)
    return x0, P0


# --------------------------------------------------------------------------- filtering

# --------------------------------------------------------------------------- smoothing

# --------------------------------------------------------------------------- scoring

@dataclass(frozen=True)
class AttitudeScores(EstimatorRun):
    """One estimator on one run, reduced (all at the star epochs, radians and rad/s).

    err_euler : (M, 3) estimate minus truth in the paper's Z-X-Y ``[roll, pitch, yaw]``
        (wrapped); sigma_euler : (M, 3) the estimator's own std of those angles.
    err_body : (M, 3) ``Log(q̂* ⊗ q)`` (body-frame attitude error); sigma_body (M, 3).
    err_bias : (M, 3) ``b - b̂``; sigma_bias (M, 3).
    nees : (M,) 6-dof NEES of ``[err_body, err_bias]``; cycles : predict + update cycles.
    The :class:`~slam.results.EstimatorRun` fields: nis (M,) per update, nis_dof; time_s
    of the ``cycles`` (smoother: the solve).
    """

    name: str
    err_euler: Array
    sigma_euler: Array
    err_body: Array
    sigma_body: Array
    err_bias: Array
    sigma_bias: Array
    nees: Array
    cycles: int


@dataclass(frozen=True)
class AttitudeTrack:
    """Run 0's estimates at the star epochs: ``quats`` (M, 4), ``bias`` (M, 3) rad/s,
    ``cov`` (M, 6, 6) tangent covariances (NaN where none)."""

    name: str
    quats: Array
    bias: Array
    cov: Array


def score_series(est: EstimateSeries, log: AttitudeLog, divergence_rad: float
                 ) -> AttitudeScores:
    """Reduce an estimator's series to :class:`AttitudeScores` against the log's truth."""
    q_true, b_true = log.star_truth_q, log.star_truth_bias
    qh, bh, P = est.means[:, :4], est.means[:, 4:], est.covs
    finite = np.all(np.isfinite(est.means), axis=1)
    M = log.n_star
    err_euler = np.full((M, 3), np.nan)
    err_body = np.full((M, 3), np.nan)
    sig_euler = np.full((M, 3), np.nan)
    if finite.any():
        err_euler[finite] = wrap_angle(q_to_euler_zxy(qh[finite]) - q_to_euler_zxy(q_true[finite]))
        err_body[finite] = QUAT.local(qh[finite], q_true[finite])
        J = euler_error_jacobian(qh[finite], q_to_euler_zxy)
        with np.errstate(invalid="ignore"):
            C = J @ P[finite, :3, :3] @ np.swapaxes(J, -1, -2)
            sig_euler[finite] = np.sqrt(np.diagonal(C, axis1=1, axis2=2))
    err_bias = b_true - bh
    with np.errstate(invalid="ignore"):
        diag = np.sqrt(np.diagonal(P, axis1=1, axis2=2))
    nees = nees_series(np.hstack([err_body, err_bias]), P)
    diverged, failure = est.diverged, est.failure
    final = np.linalg.norm(err_body[-1])
    if not diverged and not final <= divergence_rad:
        diverged = True
        failure = (f"final attitude error {np.degrees(final):.3g} deg exceeds "
                   f"{np.degrees(divergence_rad):.3g} deg")
    return AttitudeScores(est.name, err_euler, sig_euler, err_body, diag[:, :3], err_bias,
                          diag[:, 3:], nees, est.cycles, nis=est.nis, nis_dof=est.nis_dof,
                          time_s=est.time_s, diverged=diverged, failure=failure,
                          extra_time_s=est.extra_time_s)


# --------------------------------------------------------------------------- one run

def run_once(world, run: int, seed_seq: np.random.SeedSequence, filters: Sequence[str],
             keep_tracks: bool = False, reference: bool = True) -> RunOutcome:
    """Simulate run ``run`` from its own seed and score every filter and the smoother (the
    per-run path).

    ``RunOutcome.scores`` holds :class:`AttitudeScores`; with ``keep_tracks`` the tracks
    are :class:`AttitudeTrack`, ``truth`` is (M, 7) ``[q, b]`` and ``times`` the star epochs.
    """
    return run_batch(world, [run], [seed_seq], filters, keep_tracks, reference,
                     batched=False)[0]


def run_batch(world, runs: Sequence[int], seed_seqs: Sequence[np.random.SeedSequence],
              filters: Sequence[str], keep_first: bool = False, reference: bool = True,
              batched: bool = True) -> list[RunOutcome]:
    """Simulate runs ``runs`` (each from its own seed) and score every filter and the
    smoother on each; a filter with a batched form runs over all of them at once
    (:func:`batch_filter`; ``batched=False`` or a filter without it: run by run).  Every
    outcome is the one :func:`run_once` gives for that run."""
    logs = [simulate_attitude(sim_config(world), np.random.default_rng(s)) for s in seed_seqs]
    fs = world.filters
    beliefs = [initial_belief(world, log) for log in logs]
    n = logs[0].samples_per_star
    trans = interval_transition(n, logs[0].dt, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s)
    meas = [star_measurement(world.star.mode, fs.star_sigma_rad, log.star_refs)
            for log in logs]
    div = world.scoring.divergence_rad
    series: list[list[EstimateSeries]] = [[] for _ in logs]
    for name in filters:
        settings = fs.settings_of(name)
        if batched and len(logs) > 1 and make_filter(name, **settings).batched:
            got = batch_filter(logs, name, beliefs, trans, meas[0], settings)
        else:
            got = [run_filter(log, name, x0, P0, trans, m, settings)
                   for log, (x0, P0), m in zip(logs, beliefs, meas)]
        for out, g in zip(series, got):
            out.append(g)
    outcomes = []
    for i, (run, log) in enumerate(zip(runs, logs)):
        x0, P0 = beliefs[i]
        if reference:
            ref, failure = run_reference(smooth_attitude, log, x0, P0, fs.arw_rad_sqrt_s,
                                         fs.bias_rw_rad_s_sqrt_s, fs.star_sigma_rad)
            M = log.n_star  # a smoother failure: no estimate, diverged with its reason
            series[i].append(ref or EstimateSeries(
                REFERENCE, np.full((M, 7), np.nan), np.full((M, 6, 6), np.nan), M - 1,
                nis=np.full(M, np.nan), nis_dof=0, time_s=0.0, diverged=True, failure=failure))
        scores = {s.name: score_series(s, log, div) for s in series[i]}
        keep = keep_first and (run == 0 or not batched)  # run_once: as asked
        tracks = ({s.name: AttitudeTrack(s.name, s.means[:, :4], s.means[:, 4:], s.covs)
                   for s in series[i]} if keep else {})
        truth = np.hstack([log.star_truth_q, log.star_truth_bias]) if keep else None
        times = np.array(log.star_times) if keep else None
        outcomes.append(RunOutcome(run, scores, tracks, truth, None, times))  # type: ignore
    return outcomes


# --------------------------------------------------------------------------- summary

def _axes(values: Array, scale: float) -> dict[str, float]:
    return {a: float(v / scale) for a, v in zip(AXES, values)}


def convergence_time(err_norm: Array, times: Array, threshold: float) -> float:
    """First epoch after which ``err_norm`` stays below ``threshold`` (NaN if never)."""
    above = np.flatnonzero(~(err_norm < threshold))
    if above.size == 0:
        return float(times[0])
    if above[-1] == len(times) - 1:
        return float("nan")
    return float(times[above[-1] + 1])


def summarize_scores(scores: list[AttitudeScores], times: Array, steady_from: float,
                     convergence: bool = False) -> dict[str, Any]:
    """Monte Carlo summary of one estimator (a ``summary.json`` entry).

    Diverged runs are counted and left out of every statistic.
    """
    good, out = scored_runs(scores)
    if not good:
        return out
    steady = times >= steady_from
    e = np.stack([s.err_euler for s in good])  # (R, M, 3)
    out["att_mean_abs_arcsec"] = _axes(np.nanmean(np.abs(e), axis=(0, 1)), ARCSEC)
    out["att_mean_abs_steady_arcsec"] = _axes(np.nanmean(np.abs(e[:, steady]), axis=(0, 1)),
                                              ARCSEC)
    out["att_rms_steady_arcsec"] = _axes(np.sqrt(np.nanmean(e[:, steady] ** 2, axis=(0, 1))),
                                         ARCSEC)
    body = np.stack([s.err_body for s in good])
    out["att_rms_body_steady_arcsec"] = {
        a: float(v / ARCSEC) for a, v in
        zip(("x", "y", "z"), np.sqrt(np.nanmean(body[:, steady] ** 2, axis=(0, 1))))}
    eb = np.stack([s.err_bias for s in good])
    out["bias_rmse_deg_h"] = float(np.sqrt(np.nanmean(eb**2)) / DEG_H)
    out["bias_rmse_steady_deg_h"] = float(np.sqrt(np.nanmean(eb[:, steady] ** 2)) / DEG_H)
    out["bias_final_rmse_deg_h"] = float(np.sqrt(np.nanmean(eb[:, -1] ** 2)) / DEG_H)
    nees = np.stack([s.nees for s in good])  # (R, M)
    stats = anees_stats(nees, 6)
    if stats:
        per_step = per_epoch_anees(nees, 6)
        out["anees"] = stats["value"]
        out["anees_steady"] = float(np.mean(per_step[np.isfinite(per_step) & steady]))
        out["anees_bounds_95"] = stats["band"]
        out["anees_steps_inside_95"] = stats["inside"]
        out["anees_steps_above_95"] = stats["above"]
    nis = np.stack([s.nis for s in good])[:, steady]
    if np.isfinite(nis).any():
        out["nis_mean_steady"] = float(np.nanmean(nis) / good[0].nis_dof)
    out.update(timing(good))
    if convergence:
        tc = np.array([convergence_time(np.linalg.norm(s.err_body, axis=1), times, ARCMIN)
                       for s in good])
        ok = np.isfinite(tc)
        out["converge_below_1arcmin_s"] = float(np.median(tc[ok])) if ok.any() else None
        out["converge_below_1arcmin_max_s"] = float(np.max(tc[ok])) if ok.any() else None
        out["never_below_1arcmin_runs"] = int((~ok).sum())
        if not ok.any():
            why = f"no run stays below 1′ to the end (never_below_1arcmin_runs = {len(tc)})"
            out["converge_below_1arcmin_s_reason"] = why
            out["converge_below_1arcmin_max_s_reason"] = why
    return out


def summarize_attitude(world, outcomes: list[RunOutcome], filters: list[str], runs: int,
                       seed: int) -> dict:
    """The ``summary.json`` dict of an attitude campaign, with the paired ranking of the
    filters by attitude and bias MSE and the headline (:func:`slam.decision.decide`)."""
    times = np.arange(world.n_star) / world.star.rate_hz
    steady_from = world.scoring.steady_state_from_s
    conv = world.scoring.report_convergence

    def entry(name: str) -> dict[str, Any]:
        return summarize_scores([o.scores[name] for o in outcomes], times, steady_from, conv)

    ref_scores = [o.scores[REFERENCE] for o in outcomes if REFERENCE in o.scores]
    reference = {}
    if ref_scores:
        ref = summarize_scores(ref_scores, times, steady_from, conv)
        good = [s for s in ref_scores if not s.diverged]
        ref.pop("time_per_cycle_s", None)
        ref.pop("time_per_run_s", None)
        ref["time_s"] = float(np.mean([s.time_s for s in good])) if good else None
        ref["marginals_time_s"] = (float(np.mean([s.extra_time_s for s in good]))
                                   if good else None)
        reference = {REFERENCE: ref}
    summary: dict[str, Any] = {
        "world": world.name,
        "kind": world.kind,
        "runs": runs,
        "seed": seed,
        "star_mode": world.star.mode,
        "steady_state_window_s": [steady_from, world.duration_s],
        "euler_sequence": "Z-X-Y (paper): roll about X, pitch about Y, yaw about Z",
        "filters": {n: entry(n) for n in filters},
        "filter_descriptions": {n: FILTER_DESCRIPTIONS.get(n, n) for n in filters},
        "reference": reference,
        "units_note": ("paper's initial variances read as deg^2 (attitude) and (deg/h)^2 "
                       "(drift); star noise sigma 20 arcsec per axis; process noise 0.05 -> "
                       "angle random walk deg/sqrt(h), 0.02 -> bias rate random walk "
                       "(deg/h)/sqrt(h)"),
        "paper": world.paper,
    }
    return decide_attitude(world, outcomes, filters, summary)
