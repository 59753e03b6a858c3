r"""Fixed-wing UAV ([Fixed-wing EA-UKF]): one Monte Carlo run and the campaign summary.

Every run simulates the log once (:mod:`slam.kinds.fixed_wing.simulate`), draws the
initial errors from the initial covariances, and runs on it

* the EA filters ``ea-<name>`` (:mod:`slam.kinds.fixed_wing.ea`): one epoch per
  accelerometer/magnetometer update - a prediction through the epoch's mean gyro
  reading, then the update with the accelerometer/magnetometer angles;
* the INS filters ``ins-<name>`` (:mod:`slam.kinds.fixed_wing.ins`): one epoch per GNSS
  fix - the mechanisation through the epoch's IMU samples, then the GNSS update (the
  first fix, at t = 0, updates the prior); with fixes more than
  :data:`~slam.kinds.fixed_wing.simulate.INS_EPOCH_MAX_S` apart the prediction is cut into
  epochs of a whole fraction of the GNSS period, updated only at the fixes, so that the
  INS filters are scored between fixes too (``log.n_ins``);
* the GTSAM smoother (:mod:`slam.kinds.fixed_wing.reference`) on the IMU and GNSS data,
  with a state at the INS filters' epochs.

A run that keeps its tracks (run 0; every run with ``slam run --tum all``) keeps each
estimator's poses (:class:`~slam.results.PoseTrack`) for its TUM file: the INS filters and
the smoother at the INS epochs with position and the 6 × 6 covariance of
``[δp, δθ]`` (body-frame ``q = q̂ ⊗ Exp(δθ)``), the EA filters at the EA epochs with zero
position (they estimate none) and the 3 × 3 covariance of their Z-Y-X Euler angles.

Every filter is built from the world's stated settings (``[filters.unscented]`` for the
UKFs) and runs in the one loop
(:func:`estimators.loop.run_epochs`); numerical failures are counted divergences.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators.loop import BeliefRecorder, run_epochs
from estimators.models import Belief
from nav.euler import euler_zyx_errors, euler_zyx_to_q, q_to_euler_zyx
from nav.quaternion import qexp, qmul
from slam.failures import run_reference
from slam.kinds.fixed_wing.decision import decide_fixed_wing
from slam.kinds.fixed_wing.ea import ANGLES, accel_mag_angles, ea_measurement, ea_transition
from slam.kinds.fixed_wing.ea import SPACE as EA_SPACE
from slam.kinds.fixed_wing.ins import SPACE as INS_SPACE
from slam.kinds.fixed_wing.ins import InsNoise, gnss_measurement, ins_transition
from slam.kinds.fixed_wing.scoring import (
    DEG,
    FwScores,
    final_check,
    nav_nees,
    summarize_scores,
)
from slam.kinds.fixed_wing.simulate import FixedWingLog, ins_samples, simulate
from slam.kinds.fixed_wing.truth_stats import (
    accelerometer_angle_errors,
    flight_facts,
    segment_masks,
)
from slam.kinds.fixed_wing.world import FixedWingWorld
from slam.results import REFERENCE, PoseTrack, RunOutcome
from slam.scoring import nees_series

Array = NDArray[np.float64]
#: σ floor of the Markov gyro drift's prior (rad/s, 1e-3 °/h): it starts at exactly 0.
DRIFT_PRIOR_FLOOR = 1e-3 * DEG / 3600.0


def block_means(x: Array, n: int) -> Array:
    """Means of consecutive blocks of ``n`` rows (the epoch averages)."""
    return x.reshape(-1, n, x.shape[-1]).mean(axis=1)


def ea_observations(log: FixedWingLog) -> tuple[Array, Array]:
    """Per EA epoch ``j >= 1``: the mean gyro reading over the epoch (J, 3) and the
    accelerometer/magnetometer angles (J, 3) (row 0 is unused, NaN)."""
    n = log.n_ea
    gyro = np.vstack([np.full((1, 3), np.nan), block_means(log.gyro, n)])
    f = block_means(log.accel, n)
    z = np.vstack([np.full((1, 3), np.nan), accel_mag_angles(f, log.mag[1:], log.field_n)])
    return gyro, z


def ea_prior(log: FixedWingLog, rng: np.random.Generator) -> tuple[Array, Array]:
    """EA ``(x0, P0)``: truth angles plus a draw from the initial σ, zero bias."""
    ea = log.world.ea
    sig = np.concatenate([ea.initial_sigma_rad, np.full(3, ea.initial_bias_sigma_rad_s)])
    x0 = np.concatenate([q_to_euler_zyx(log.traj.q[0]), np.zeros(3)])
    x0[:3] += rng.standard_normal(3) * sig[:3]
    return EA_SPACE.retract(x0, np.zeros(6)), np.diag(sig**2)


def ins_prior(log: FixedWingLog, rng: np.random.Generator) -> tuple[Array, Array]:
    """INS ``(x0, P0)``: truth plus draws from the initial σ, zero drifts."""
    w = log.world
    sig = np.concatenate([np.full(3, w.ins.initial_position_sigma_m),
                          np.full(3, w.ins.initial_velocity_sigma_mps),
                          w.ins.initial_attitude_sigma_rad,
                          np.full(3, w.imu.gyro_bias_sigma_rad_s),
                          np.full(3, DRIFT_PRIOR_FLOOR),
                          np.full(3, w.imu.accel_drift_sigma_mps2)])
    sig = np.maximum(sig, DRIFT_PRIOR_FLOOR)
    d = rng.standard_normal(9) * sig[:9]
    tr = log.traj
    x0 = np.concatenate([tr.p[0] + d[:3], tr.v[0] + d[3:6], qmul(tr.q[0], qexp(d[6:9])),
                         np.zeros(9)])
    return x0, np.diag(sig**2)


def ins_noise(world: FixedWingWorld) -> InsNoise:
    i = world.imu
    return InsNoise(i.gyro_arw_rad_sqrt_s, i.accel_vrw_mps_sqrt_s, i.gyro_drift_rw_rad_s_sqrt_s,
                    i.accel_drift_rw_mps2_sqrt_s, i.gyro_drift_time_s, i.accel_drift_time_s)


def ins_track(times: Array, means: Array, covs: Array) -> PoseTrack:
    """The poses of an INS-state series (G, 19) with the ``[δp, δθ]`` block of its
    covariance (G, ≥9, ≥9)."""
    idx = np.r_[0:3, 6:9]
    return PoseTrack(times, means[:, 0:3].copy(), means[:, 6:10].copy(),
                     covs[:, idx[:, None], idx[None, :]])


def run_ea(log: FixedWingLog, name: str, x0: Array, P0: Array,
           keep: dict[str, PoseTrack] | None = None) -> FwScores:
    """EA filter ``name`` (``ea-<filter>``) over the log (module docstring); ``keep``
    receives its poses (zero position, Euler-angle covariance)."""
    w = log.world
    flt = w.filters.make(name)
    gyro, z = ea_observations(log)
    J, tau = z.shape[0], log.n_ea * log.dt
    meas = ea_measurement(w.ea.roll_pitch_sigma_rad, w.ea.heading_sigma_rad)
    rec = BeliefRecorder.empty(J, 6, 6)

    def transition(j: int, b: Belief):
        return ea_transition(b.mean, tau, w.imu.gyro_arw_rad_sqrt_s,
                             w.imu.gyro_drift_rw_rad_s_sqrt_s, log.earth_rate), gyro[j]

    def correct(j: int, b: Belief):
        post, inn = flt.update(b, meas, z[j])
        return post, [inn]

    out = run_epochs(flt, flt.init(x0, EA_SPACE, cov=P0), J, transition=transition,
                     correct=correct, record=rec)
    samples = np.arange(J) * log.n_ea
    truth = q_to_euler_zyx(log.traj.q[samples])
    err = ANGLES.local(truth, rec.means[:, :3])
    sig = np.sqrt(np.diagonal(rec.covs[:, :3, :3], axis1=1, axis2=2))
    nees = nees_series(-err, rec.covs[:, :3, :3])
    div, why = final_check(err, out.diverged, out.failure, w.scoring.divergence_rad)
    if keep is not None:
        keep[name] = PoseTrack(samples * log.dt, None, euler_zyx_to_q(*rec.means[:, :3].T),
                               rec.covs[:, :3, :3].copy())
    return FwScores(name, samples * log.dt, err, sig, None, None,
                    *segment_masks(log.world, samples), nees, 3, J - 1, nis=out.nis, nis_dof=3,
                    time_s=out.time_s, diverged=div, failure=why)


def run_ins(log: FixedWingLog, name: str, x0: Array, P0: Array,
            keep: dict[str, PoseTrack] | None = None) -> FwScores:
    """INS filter ``name`` (``ins-<filter>``) over the log (module docstring); ``keep``
    receives its poses (:func:`ins_track`)."""
    w = log.world
    flt = w.filters.make(name)
    n, G, every = log.n_ins, log.ins_epochs, log.fix_every
    noise = ins_noise(w)
    meas = gnss_measurement(w.gnss.horizontal_sigma_m, w.gnss.vertical_sigma_m,
                            w.gnss.velocity_sigma_mps)
    z = np.hstack([log.gnss_p, log.gnss_v])
    rec = BeliefRecorder.empty(G, 19, 18)

    def transition(i: int, b: Belief):
        sl = slice((i - 1) * n, i * n)
        return ins_transition(b.mean, log.gyro[sl], log.accel[sl], log.dt, log.gravity,
                              log.earth_rate, noise), None

    def correct(i: int, b: Belief):
        if i % every:
            return b, []  # between fixes: the prediction is the estimate
        post, inn = flt.update(b, meas, z[i // every])
        return post, [inn]

    out = run_epochs(flt, flt.init(x0, INS_SPACE, cov=P0), G, transition=transition,
                     correct=correct, record=rec, correct_first=True)
    if keep is not None:
        keep[name] = ins_track(np.arange(G) * n * log.dt, rec.means, rec.covs)
    return nav_scores(log, name, rec.means, rec.covs, out.nis, out.time_s, G - 1,
                      out.diverged, out.failure)


def nav_scores(log: FixedWingLog, name: str, means: Array, covs: Array, nis: Array,
               time_s: float, cycles: int, diverged: bool, failure: str | None,
               note: str | None = None) -> FwScores:
    """Scores of an INS-state series ``means`` (G, 19), ``covs`` (G, ≥9, ≥9) at the
    epochs of the GNSS-aided estimators (the INS filters and the smoother; ``log.n_ins``
    samples apart)."""
    samples = np.arange(means.shape[0]) * log.n_ins
    tr = log.traj
    qh = means[:, 6:10]
    err, sig = euler_zyx_errors(qh, covs[:, 6:9, 6:9], tr.q[samples])
    ep, ev = means[:, 0:3] - tr.p[samples], means[:, 3:6] - tr.v[samples]
    nees = nav_nees(ep, ev, qh, tr.q[samples], covs[:, :9, :9])
    div, why = final_check(err, diverged, failure, log.world.scoring.divergence_rad)
    with np.errstate(invalid="ignore"):
        sp = np.sqrt(np.diagonal(covs[:, 0:3, 0:3], axis1=1, axis2=2))
        sv = np.sqrt(np.diagonal(covs[:, 3:6, 3:6], axis1=1, axis2=2))
    return FwScores(name, samples * log.dt, err, sig, ep, ev, *segment_masks(log.world, samples),
                    nees, 9, cycles, note, sp, sv, nis=nis, nis_dof=6, time_s=time_s, diverged=div,
                    failure=why)


def _reference(log: FixedWingLog, x0: Array, P0: Array,
               keep: dict[str, PoseTrack] | None = None) -> FwScores:
    from slam.kinds.fixed_wing.reference import smooth

    est, failure = run_reference(smooth, log, x0, P0)
    if est is not None and keep is not None:
        keep[REFERENCE] = ins_track(np.arange(est[0].shape[0]) * log.n_ins * log.dt,
                                    est[0], est[1])
    if est is None:
        G = log.ins_epochs
        nan = np.full((G, 19), np.nan)
        return nav_scores(log, REFERENCE, nan, np.full((G, 9, 9), np.nan), np.zeros(0), 0.0,
                          G - 1, True, failure)
    means, covs, time_s, note = est
    return nav_scores(log, REFERENCE, means, covs, np.zeros(0), time_s, means.shape[0] - 1,
                      False, None, note)


def run_once(world: FixedWingWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False, reference: bool = True
             ) -> RunOutcome:
    """Simulate run ``run`` from its own seed; score every estimator and the smoother.

    With ``keep_tracks`` the tracks are each estimator's :class:`~slam.results.PoseTrack`
    (module docstring) and ``truth`` is (G, 7) ``[p, q_nb]`` at the INS epochs."""
    rng = np.random.default_rng(seed_seq)
    log = simulate(world, rng)
    ea0, ins0 = ea_prior(log, rng), ins_prior(log, rng)
    scores: dict[str, FwScores] = {}
    keep: dict[str, PoseTrack] | None = {} if keep_tracks else None
    for name in filters:
        scores[name] = (run_ea(log, name, *ea0, keep=keep) if name.startswith("ea-")
                        else run_ins(log, name, *ins0, keep=keep))
    if reference:
        scores[REFERENCE] = _reference(log, *ins0, keep=keep)
    samples = np.arange(log.ins_epochs) * log.n_ins
    times = samples * log.dt
    if keep is None:
        return RunOutcome(run, scores, times=times)  # type: ignore[arg-type]
    truth = np.hstack([log.traj.p[samples], log.traj.q[samples]])
    return RunOutcome(run, scores, keep, truth, times=times)  # type: ignore[arg-type]


def summarize(world: FixedWingWorld, outcomes: list[RunOutcome], filters: list[str], runs: int,
              seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a fixed-wing campaign."""

    def entry(name: str) -> dict[str, Any]:
        return summarize_scores([o.scores[name] for o in outcomes if name in o.scores])

    reference = {}
    if any(REFERENCE in o.scores for o in outcomes):
        reference = {REFERENCE: entry(REFERENCE)}
    summary = {
        "world": world.name, "kind": world.kind, "runs": runs, "seed": seed,
        "duration_s": world.duration_s, "imu_rate_hz": world.imu.rate_hz,
        "ea_rate_hz": world.ea.update_rate_hz, "gnss_rate_hz": world.gnss.rate_hz,
        "ins_epoch_s": ins_samples(world) * world.imu.dt_s,
        "initial_heading_sigma_deg": {"ea": float(np.degrees(world.ea.initial_sigma_rad[2])),
                                      "ins": float(np.degrees(
                                          world.ins.initial_attitude_sigma_rad[2]))},
        "euler_sequence": "Z-Y-X (yaw, pitch, roll); body forward-left-up, navigation ENU",
        "flight": flight_facts(world),
        "accelerometer_angle_error_deg": accelerometer_angle_errors(world),
        "filters": {n: entry(n) for n in filters},
        "reference": reference,
        "paper": world.paper,
    }
    return decide_fixed_wing(world, outcomes, filters, summary)
