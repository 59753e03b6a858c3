r"""Drone SINS/SLAM scenario: simulate, filter, smooth, score, summarise.

One Monte Carlo run (:func:`run_once`):

1. **Truth** (deterministic per world, cached per process): the terrain mesh
   (:func:`build_terrain`), the landmarks placed on it, and the flight
   (:func:`slam.kinds.drone.flight.fly`): Bailey-style steering through the waypoints at a constant
   height above the ground, multirotor attitude, error-free IMU readings whose
   mechanisation *is* the truth.
2. **Log** (:func:`simulate_drone`, from the run's seed): IMU biases, bias random walks
   and white noise (:func:`nav.imu_errors.corrupt_imu`); landmark observations
   ``[range, azimuth, elevation]`` in the body frame at every sensor epoch, for the
   landmarks within range, inside the field of view and - with ``line_of_sight`` - not
   hidden by the terrain (segment-mesh intersection); the filters' initial state drawn
   about the truth from the initial covariance.
3. **Estimators** on the same log: every filter in joint mode
   (:func:`run_drone_filter`: one prediction per sensor epoch through its IMU samples,
   batch update with the re-observed landmarks, then augmentation with the new ones;
   :mod:`slam.kinds.drone.models`), the IMU-only baseline (:func:`imu_only`: pure
   mechanisation from the initial state with zero bias estimates, covariance by the
   EKF's prediction), the GTSAM smoother (:mod:`slam.kinds.drone.reference`) and, with
   ``[filters] online``, the online row ``isam2`` (:mod:`slam.kinds.drone.online`),
   scored like a filter and not ranked.
4. **Scores** (:class:`DroneScores`) at the sensor epochs: position error (ENU, m) and
   its own σ; roll/pitch/yaw error (aerospace Z-Y-X Euler angles of ``q_nb`` with body
   forward-left-up: roll about x, pitch about y, positive nose-down; yaw from east,
   counter-clockwise); NEES of the 3-dof position and of the 6-dof pose
   ``[δp, δθ]`` (δθ body-frame); final landmark errors; NIS.

Numerical failure or a position error above ``divergence_m`` ends a filter's run; it is
reported as diverged, never raised.  :func:`summarize_drone` builds the ``summary.json``
dict: the headline ANEES is the **3-dof position** ANEES (``anees``, band
``anees_bounds_95``); the 6-dof pose ANEES is reported next to it (``anees_pose6``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from slam.decision import Consistency, decide
from slam.failures import run_reference
from slam.kinds.drone.filtering import IMU_ONLY, DroneEstimate, imu_only, run_drone_batch
from slam.kinds.drone.online import online_drone
from slam.kinds.drone.reference import failed_reference, smooth_drone
from slam.kinds.drone.scoring import score, summarize_scores, track_of
from slam.kinds.drone.simulate import simulate_drone
from slam.kinds.drone.truth import truth_of
from slam.kinds.drone.variants import INVARIANT_BASES
from slam.kinds.planar.world import ONLINE
from slam.ranking import Metric, per_run, per_run_mse
from slam.results import REFERENCE, RunOutcome
from slam.scoring import landmark_anees_entries

FILTER_DESCRIPTIONS = {
    "ekf": "EKF-SLAM: error-state EKF, quaternion retracted by multiplication",
    "ckf": "cubature Kalman filter (dense covariance)",
    "ukf": "unscented Kalman filter (dense covariance)",
    "cdkf": "central-difference Kalman filter (dense covariance)",
    "srckf": "quaternion SRCKF-SLAM (the paper's): square-root cubature filter",
    "srukf": "quaternion SRUKF-SLAM: square-root unscented filter",
    "srcdkf": "quaternion SRCDKF-SLAM: square-root central-difference filter",
    "svdckf": "cubature Kalman filter with an SVD-factored covariance",
    "iekf": "iterated EKF-SLAM: Gauss-Newton measurement update with step control",
    "isrckf": "square-root cubature filter, iterated posterior-linearisation update",
    "isrukf": "square-root unscented filter, iterated posterior-linearisation update",
}
FILTER_DESCRIPTIONS.update({
    f"{b}-inv": f"{FILTER_DESCRIPTIONS[b]}; right-invariant error on SE_2+n(3) x IMU biases"
    for b in INVARIANT_BASES})


# --------------------------------------------------------------------------- one run

def run_once(world, run: int, seed_seq: np.random.SeedSequence, filters: Sequence[str],
             keep_tracks: bool = False, reference: bool = True) -> RunOutcome:
    """Simulate run ``run`` from its own seed; score every filter, the IMU-only baseline
    and (``reference``) the GTSAM smoother on the same log (the per-run path).

    ``RunOutcome.scores`` holds :class:`DroneScores`; with ``keep_tracks`` the tracks are
    :class:`DroneTrack`, ``truth`` is (E, 16) ``[p, v, q, b_g, b_a]``, ``true_landmarks``
    (N, 3) and ``times`` the epochs (s).
    """
    return run_batch(world, [run], [seed_seq], filters, keep_tracks, reference,
                     batched=False)[0]


def run_batch(world, runs: Sequence[int], seed_seqs: Sequence[np.random.SeedSequence],
              filters: Sequence[str], keep_first: bool = False, reference: bool = True,
              batched: bool = True) -> list[RunOutcome]:
    """Simulate runs ``runs`` (each from its own seed) and score every estimator on each:
    the filters over the runs at once where they share a layout
    (:func:`~slam.kinds.drone.filtering.run_drone_batch`; ``batched=False``: one by one), the
    IMU-only baseline and the smoother per run.  Every outcome is :func:`run_once`'s."""
    fs = world.filters
    logs = [simulate_drone(world, np.random.default_rng(s)) for s in seed_seqs]
    ests: list[list] = [[] for _ in logs]
    for name in filters:
        got = run_drone_batch(logs, name, association=fs.association,
                              gates=(fs.gate_accept, fs.gate_new), diverge_m=fs.divergence_m,
                              imu_noise_scale=fs.imu_noise_scale,
                              sensor_noise_scale=fs.sensor_noise_scale, mode=fs.mode,
                              filter_params=fs.settings_of(name), batched=batched)
        for out, e in zip(ests, got):
            out.append(e)
    outcomes = []
    for i, (run, log) in enumerate(zip(runs, logs)):
        if getattr(fs, "online", False):
            ests[i].append(_online(log, fs))
        ests[i].append(imu_only(log, fs.imu_noise_scale))
        if reference:
            ref, failure = run_reference(smooth_drone, log, imu_noise_scale=fs.imu_noise_scale,
                                         sensor_noise_scale=fs.sensor_noise_scale)
            ests[i].append(ref if ref is not None else failed_reference(log, failure or ""))
        keep = keep_first and (run == 0 or not batched)  # run_once: as asked
        scores = {e.name: score(e, log) for e in ests[i]}
        tracks = {e.name: track_of(e) for e in ests[i]} if keep else {}
        outcomes.append(RunOutcome(run, scores, tracks,  # type: ignore[arg-type]
                                   log.truth if keep else None,
                                   log.landmarks if keep else None,
                                   log.times if keep else None))
    return outcomes


def _online(log, fs) -> DroneEstimate:
    """The online row on ``log`` (:func:`~slam.kinds.drone.online.online_drone`); a
    numerical failure marks it diverged on this run with its reason."""
    est, failure = run_reference(online_drone, log, imu_noise_scale=fs.imu_noise_scale,
                                 sensor_noise_scale=fs.sensor_noise_scale)
    if est is not None:
        return est
    failed = failed_reference(log, failure or "")
    return replace(failed, name=ONLINE)


def headline_metrics(outcomes: list[RunOutcome], names: Sequence[str]) -> list[Metric]:
    """The drone's headline metrics, each filter's per-run MSE over the sensor epochs:
    3-D position (m), yaw (deg; the attitude angle the landmarks observe least) and the
    final landmark positions (m)."""
    return [
        Metric("position", "position", "m", {n: per_run(outcomes, n, lambda s: float(
            per_run_mse(s.err_pos[None])[0])) for n in names}),
        Metric("yaw", "yaw", "deg", {n: per_run(outcomes, n, lambda s: float(
            per_run_mse(np.degrees(s.err_att[None, :, 2]))[0])) for n in names}),
        Metric("landmarks", "landmarks (final)", "m", {n: per_run(outcomes, n, lambda s: float(
            np.mean(s.lm_err**2)) if s.lm_err.size else np.nan) for n in names}),
    ]


def _map_consistency(outcomes: list[RunOutcome], name: str, epochs: int) -> dict[str, Any]:
    """The landmark ANEES entries of filter ``name`` over the runs it finished."""
    series = [o.scores[name].map_series for o in outcomes
              if name in o.scores and not o.scores[name].diverged
              and o.scores[name].map_series is not None]
    return landmark_anees_entries(series, epochs)


def summarize_drone(world, outcomes: list[RunOutcome], filters: list[str], runs: int,
                    seed: int) -> dict:
    """The ``summary.json`` dict of a drone SINS/SLAM campaign, with the paired ranking of
    the filters by position, yaw and landmark MSE, the landmark ANEES and the headline
    (:func:`slam.decision.decide`)."""
    traj, _ = truth_of(world)
    n = world.samples_per_epoch
    times = np.arange(traj.n_samples // n + 1) * n * traj.dt
    loops = (traj.loop_end_steps * traj.dt).tolist()

    def entry(name: str) -> dict[str, Any]:
        return summarize_scores([o.scores[name] for o in outcomes if name in o.scores],
                                times, loops)

    out: dict[str, Any] = {
        "world": world.name,
        "kind": world.kind,
        "runs": runs,
        "seed": seed,
        "filters": {n_: entry(n_) for n_ in filters},
        "filter_descriptions": {n_: FILTER_DESCRIPTIONS.get(n_, n_) for n_ in filters},
        "baselines": {IMU_ONLY: entry(IMU_ONLY)},
    }
    if any(ONLINE in o.scores for o in outcomes):
        out["online"] = {ONLINE: entry(ONLINE)}
    if any(REFERENCE in o.scores for o in outcomes):
        ref = entry(REFERENCE)
        good = [o.scores[REFERENCE] for o in outcomes
                if REFERENCE in o.scores and not o.scores[REFERENCE].diverged]
        for key in ("time_per_step_s", "time_per_run_s"):
            ref.pop(key, None)
        if good:
            ref["time_s"] = float(np.mean([s.time_s for s in good]))
            ref["marginals_time_s"] = float(np.mean([s.extra_time_s for s in good]))
        out["reference"] = {REFERENCE: ref}
        ref_lm = ref.get("landmark_rmse_m")
        if ref_lm:
            for name in filters:
                f = out["filters"][name]
                if "landmark_rmse_m" in f:
                    f["landmark_rmse_vs_gtsam"] = f["landmark_rmse_m"] / ref_lm
    out["flight"] = {
        "duration_s": float(times[-1]),
        "epochs": int(len(times)),
        "loop_end_times_s": loops,
        "speed_mps": world.vehicle.speed_mps,
        "height_above_ground_m": world.vehicle.height_above_ground_m,
        "terrain": world.terrain.kind,
        "imu_rate_hz": world.imu.rate_hz,
        "sensor_rate_hz": world.sensor.rate_hz,
    }
    out["conventions"] = {
        "frames": "ENU navigation frame, forward-left-up body frame, q_nb Hamilton",
        "euler": "Z-Y-X (yaw about z, then pitch about y, then roll about x); "
                 "pitch positive nose-down in forward-left-up",
        "anees": "headline anees is the 3-dof position NEES / 3; anees_pose6 the 6-dof "
                 "[position, body-frame attitude] NEES / 6",
        "mechanisation": "flat-Earth local-level ENU, gravity constant, Earth rate "
                         + ("on" if world.imu.earth_rate else "off"),
    }
    out["paper"] = world.paper
    for name in filters:
        out["filters"][name].update(_map_consistency(outcomes, name, len(times)))
    if "online" in out:
        out["online"][ONLINE].update(_map_consistency(outcomes, ONLINE, len(times)))
    fs = world.filters
    return decide(out, headline_metrics(outcomes, [*filters, REFERENCE]), filters=filters,
                  consistency=Consistency(label="position"),
                  tuned=fs,
                  variants={b: f"{b}-inv" for b in INVARIANT_BASES})
