r"""One Monte Carlo run of the ``spinning`` kind: simulate, filter, smooth, score, and the
run's share of the noise-mismatch sweep.

Scores (:class:`SpinScores`), per estimator, at every epoch:

* pitch and yaw errors :math:`\hat x - x` (rad, wrapped), the estimator's own σ, and the
  2-dof NEES :math:`e^\top P^{-1} e`;
* the roll each estimator implies: eq. 7-8 (:func:`~slam.kinds.spinning.truth.roll_from_field`)
  on the measured radial components with *its* pitch and yaw, minus the true roll
  (wrapped to ±180°: at 10 Hz and 10-20 rev/s the turn count is aliased, so only the
  angle is scored);
* the NIS of each update and the updates whose H∞ existence condition failed.

A world whose calibrated drag does not give its targets' flight is a world error
(:func:`checked_flight`), found before the first run simulates anything.

A run is diverged when the loop failed (its reason is kept) or when the final pitch or yaw
error exceeds ``[scoring] divergence_deg``.

Seeds: the run draws from its own ``SeedSequence``; sweep log ``t`` draws from
``SeedSequence(entropy, spawn_key=(SWEEP_KEY, t))`` of the campaign's entropy, so the sweep
does not depend on which run computes it (run ``t`` does, for ``t`` < the sweep's tasks).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

import slam.kinds.spinning.sweep as sw
from estimators import wrap_angle
from slam.failures import run_reference
from slam.kinds.spinning.models import (
    Models,
    RunFacts,
    Series,
    facts,
    run_filter,
    smooth,
    world_models,
)
from slam.kinds.spinning.simulate import SpinLog, sim_config, simulate
from slam.kinds.spinning.truth import (
    CALIBRATION_TOLERANCE,
    Flight,
    blind_area,
    calibration_miss,
    radial_blind,
    roll_from_field,
    target_misses,
    trajectory,
)
from slam.kinds.spinning.world import SpinningWorld
from slam.results import REFERENCE, RunOutcome
from slam.scoring import nees_series

Array = NDArray[np.float64]

SWEEP_KEY = 2**32 - 1
"""First spawn-key element of the sweep's seed sequences (the runs' keys are ``(i,)``)."""


@dataclass(frozen=True, kw_only=True)
class SpinScores(RunFacts):
    """One estimator on one run (E epochs, radians) and how the run went (:class:`RunFacts`).

    err, sigma : (E, 2) pitch/yaw error and own σ; nees : (E,) 2-dof; roll_err : (E,);
    nis : (E,) (NaN for the smoother), each of ``nis_dof`` (one axial reading).
    """

    name: str
    err: Array
    sigma: Array
    nees: Array
    roll_err: Array
    nis: Array
    nis_dof: int = 1


@dataclass(frozen=True)
class SpinTrack:
    """Run 0's estimates: ``means`` (E, 2), ``covs`` (E, 2, 2), ``roll`` (E,) rad, and the
    epochs of the H∞ existence failures."""

    name: str
    means: Array
    covs: Array
    roll: Array
    fallback_epochs: Array


@dataclass(frozen=True)
class SpinOutcome(RunOutcome):
    """A run's outcome plus its share of the sweep, its magnetometer-only roll error
    (eq. 7-8 with the *true* pitch and yaw: the floor any filter's roll can reach), and the
    epochs the measured-radial-field detector (:func:`~slam.kinds.spinning.truth.radial_blind`)
    flags as blind, and the prior draw's error over its σ (pitch, yaw)."""

    sweep: tuple[sw.SweepRecord, ...] = ()
    roll_floor_err: Array | None = None
    blind_detected: Array | None = None
    prior_z: Array | None = None


def implied_roll(world: SpinningWorld, log: SpinLog, means: Array) -> Array:
    """Eq. 7-8 on the measured radial field with the estimated pitch and yaw (rad)."""
    return roll_from_field(world.field, means[:, 0], means[:, 1], log.mag[:, 1], log.mag[:, 2])


def score(world: SpinningWorld, s: Series, log: SpinLog) -> SpinScores:
    """Reduce a series to :class:`SpinScores` against the log's truth (module docstring)."""
    err = wrap_angle(s.means - log.truth)
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.diagonal(s.covs, axis1=1, axis2=2))
    roll_err = wrap_angle(implied_roll(world, log, s.means) - log.gamma)
    run = facts(s)
    final = np.abs(err[-1])
    if not s.diverged and not np.all(final <= world.scoring.divergence_rad):
        run["diverged"] = True
        run["failure"] = (f"final pitch/yaw error {np.degrees(final[0]):.3g}/"
                          f"{np.degrees(final[1]):.3g} deg exceeds "
                          f"{np.degrees(world.scoring.divergence_rad):.3g} deg")
    return SpinScores(name=s.name, err=err, sigma=sigma, nees=nees_series(err, s.covs),
                      roll_err=roll_err, nis=s.nis, **run)


def estimate(world: SpinningWorld, log: SpinLog, m: Models, filters: Sequence[str],
             reference: bool = True) -> list[Series]:
    """Every filter, then the GTSAM smoother, on one log."""
    series = [run_filter(log, name, m) for name in filters]
    if reference:
        ref, failure = run_reference(smooth, log, m, world.field,
                                     world.gyro.rate_noise_rad_s_sqrt_hz,
                                     world.magnetometer.noise_nt)
        E = log.n_epochs  # a smoother failure: no estimate, diverged with its reason
        series.append(ref or Series(name=REFERENCE, means=np.full((E, 2), np.nan),
                                    covs=np.full((E, 2, 2), np.nan), nis=np.full(E, np.nan),
                                    time_s=0.0, cycles=E - 1, diverged=True, failure=failure))
    return series


def run_once(world: SpinningWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False, reference: bool = True
             ) -> SpinOutcome:
    """Simulate run ``run``, score every filter and the smoother, and compute sweep log
    ``run`` if the sweep has that many (module docstring)."""
    checked_flight(world)
    rng = np.random.default_rng(seed_seq)
    cfg = sim_config(world)
    log = simulate(cfg, rng)
    m = world_models(world, log, rng)
    series = estimate(world, log, m, filters, reference)
    scores = {s.name: score(world, s, log) for s in series}
    tracks = {}
    if keep_tracks:
        tracks = {s.name: SpinTrack(s.name, s.means, s.covs, implied_roll(world, log, s.means),
                                    s.fallback_epochs) for s in series}
    sweep: tuple[sw.SweepRecord, ...] = ()
    if run < world.sweep.tasks:
        child = np.random.SeedSequence(seed_seq.entropy, spawn_key=(SWEEP_KEY, run))
        sweep = (sw.sweep_task(world, cfg, run, np.random.default_rng(child)),)
    floor = wrap_angle(implied_roll(world, log, log.truth) - log.gamma)
    truth = np.column_stack([log.alpha, log.beta, log.gamma]) if keep_tracks else None
    times = np.array(log.times) if keep_tracks else None
    detected = radial_blind(world.field, log.mag, world.scoring.blind_area_rad)
    sd = np.sqrt(np.diag(m.P0))  # 0 for a prior known exactly: its draw is 0 too
    prior_z = np.divide(m.x0 - log.truth[0], sd, out=np.zeros_like(sd), where=sd > 0)
    return SpinOutcome(run, scores, tracks, truth, None, times, sweep,  # type: ignore[arg-type]
                       floor, detected, prior_z)


def blind_mask(world: SpinningWorld, alpha: Array, beta: Array) -> Array:
    """The epochs in the geomagnetic blind area (``[scoring] blind_area_deg``)."""
    return blind_area(world.field, alpha, beta, world.scoring.blind_area_rad)


def checked_flight(world: SpinningWorld) -> Flight:
    """The world's flight; a ``WorldError`` naming the key when it cannot be flown, or its
    drag is calibrated and misses the targets
    (:func:`~slam.kinds.spinning.truth.calibration_miss`)."""
    from worlds.schema import WorldError

    try:
        f = trajectory(world.flight)
    except ValueError as exc:
        raise WorldError(world.source or world.name, "flight",
                         f"{exc} (launch speed_mps, pitch_deg; scale_height_m, drag_k_per_m)"
                         ) from None
    if why := calibration_miss(world.flight, f):
        raise WorldError(world.source or world.name, *why)
    return f


def flight_facts(world: SpinningWorld) -> dict[str, Any]:
    """The flown trajectory's numbers next to Table 2's targets: ``target_miss`` the relative
    miss of each (flown / target - 1), within ``calibration_tolerance`` when the drag is
    calibrated (:func:`checked_flight`); ``warning`` when a given drag misses by more."""
    f = checked_flight(world)
    fs = world.flight
    miss = target_misses(fs, f)
    worst = max(miss, key=lambda key: abs(miss[key]))
    warning = {}
    if fs.drag_k_per_m is not None and abs(miss[worst]) > CALIBRATION_TOLERANCE:
        warning = {"warning": f"the drag is given (drag_k_per_m = {fs.drag_k_per_m:g} /m), not "
                              f"calibrated, and the flight misses {worst} by "
                              f"{100 * miss[worst]:+.1f} % (more than "
                              f"{100 * CALIBRATION_TOLERANCE:g} %): it is not Table 2's flight"}
    return {"drag_k_per_m": f.k_per_m, "drag_calibrated": fs.drag_k_per_m is None,
            "calibration_tolerance": CALIBRATION_TOLERANCE, "target_miss": miss, **warning,
            "flight_time_s": f.flight_time_s, "range_m": f.range_m, "apex_m": f.apex_m,
            "target_flight_time_s": fs.target_flight_time_s,
            "target_range_m": fs.target_range_m, "target_apex_m": fs.target_apex_m,
            "spin_rev_s": world.spin.rate_rev_s, "spin_decay_time_s": world.spin.decay_time_s,
            "crosswind_mps": fs.crosswind_mps, "launch_pitch_deg": math.degrees(fs.pitch_rad)}
