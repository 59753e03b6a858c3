r"""Alignment ([Wu-Wang 2014]): one Monte Carlo run and the campaign summary.

Every run simulates the log once (:mod:`slam.kinds.alignment.simulate`) and runs on it

* the world's filters (``[filters] names``), each built from its stated settings
  (``[filters.unscented]`` α, β, κ for ``ukf`` / ``uthinf``; ``[filters.hinf]`` γ and
  ``on_failure`` for ``uthinf`` / ``srchinf``: ``"raise"`` ends the run as diverged with
  its reason at a Riccati-condition failure, ``"kalman"`` takes the Kalman update for that
  step and counts it), on the AQE model
  (:mod:`slam.kinds.alignment.models`): first update at t = 0, then one prediction
  through the interval's 100 IMU samples and one velocity update per 100 ms, through the
  one filter loop :func:`estimators.loop.run_epochs`;
* the GTSAM smoother (:mod:`slam.kinds.alignment.reference`) on the first
  ``[reference] runs`` runs;
* the γ sweep (:mod:`slam.kinds.alignment.sweep`) on the first ``[sweep] runs`` runs.

A run that keeps its tracks (run 0; every run with ``slam run --tum all``) keeps each
estimator's corrected attitude :math:`q_{est}` and its misalignment covariance
(:class:`~slam.results.PoseTrack`, no position) for its TUM file: the filters at every
epoch, the smoother at its keys.

Scores: the residual misalignment (East, North, azimuth = Up) of the corrected attitude
against the truth, its σ from the estimator's covariance, the 3-dof misalignment NEES
the 2-dof NEES of the level axes alone, and the 13-dof NEES of the whole error state
(filters only).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators import Euclidean
from estimators.loop import BeliefRecorder, run_epochs
from estimators.models import Belief
from nav.quaternion import qnormalize
from slam.kinds.alignment.models import (
    N_STATE,
    aqe_transition,
    initial_belief,
    misalignment_error,
    true_state,
    velocity_measurement,
)
from slam.kinds.alignment.reference import smooth_alignment
from slam.kinds.alignment.scoring import AlignScores
from slam.kinds.alignment.simulate import AlignmentLog, simulate_alignment
from slam.kinds.alignment.sweep import SweepCell, sweep_run
from slam.kinds.alignment.world import AlignmentWorld
from slam.results import REFERENCE, PoseTrack, RunOutcome
from slam.scoring import nees_series

Array = NDArray[np.float64]


def run_filter(world: AlignmentWorld, log: AlignmentLog, name: str, flt: Any = None,
               keep: dict[str, PoseTrack] | None = None) -> AlignScores:
    """Filter ``name`` over the log (module docstring), scored against the truth;
    ``flt`` replaces the filter the world's settings make (the γ sweep); ``keep`` receives
    its attitude track."""
    flt = world.filters.make(name) if flt is None else flt
    x0, P0 = initial_belief(world, log)
    M = log.n_epochs
    rec = BeliefRecorder.empty(M, N_STATE, N_STATE)
    trans = aqe_transition(world, log)
    meas = velocity_measurement(world.filters.velocity_sigma_mps)

    falls = [0]

    def correct(j: int, belief: Belief) -> tuple[Belief, list]:
        post, innovation = flt.update(belief, meas, log.sins_v[j])
        falls[0] += innovation.hinf_fallback
        return post, [innovation]

    out = run_epochs(flt, flt.init(x0, Euclidean(N_STATE), cov=P0), M, correct_first=True,
                     transition=lambda j, b: (trans, j - 1), correct=correct, record=rec)
    nis = np.full(M, np.nan)
    nis[out.nis_epoch] = out.nis
    err, cov = misalignment_error(log.sins_q, rec.means[:, :4], rec.covs[:, :4, :4],
                                  log.truth_q)
    nees13 = nees_series(true_state(log) - rec.means, rec.covs)
    if keep is not None:
        keep[name] = PoseTrack(np.array(log.times), None,
                               qnormalize(log.sins_q - rec.means[:, :4]), cov)
    return _scores(name, err, cov, nees13, nis, 3, out.time_s, M - 1, out.failure, world,
                   fallbacks=falls[0], updates=len(out.nis))


def _scores(name: str, err: Array, cov: Array, nees13: Array, nis: Array, nis_dof: int,
            time_s: float, cycles: int, failure: str | None, world: AlignmentWorld,
            note: str | None = None, fallbacks: int = 0, updates: int = 0) -> AlignScores:
    """Assemble :class:`AlignScores`; a final error beyond the world's bound is a
    divergence with its reason."""
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    final = err[np.all(np.isfinite(err), axis=1)]
    size = float(np.degrees(np.linalg.norm(final[-1, :2]))) if len(final) else np.inf
    if failure is None and not size <= np.degrees(world.scoring.divergence_rad):
        failure = (f"final level misalignment error {size:.3g} deg exceeds "
                   f"{np.degrees(world.scoring.divergence_rad):.3g} deg")
    return AlignScores(name, err, sigma, nees_series(err, cov), nees13,
                       nees_series(err[:, :2], cov[:, :2, :2]), cycles, note, fallbacks,
                       updates, nis=nis,
                       nis_dof=nis_dof, time_s=time_s, diverged=failure is not None,
                       failure=failure)


def run_reference(world: AlignmentWorld, log: AlignmentLog,
                  keep: dict[str, PoseTrack] | None = None) -> AlignScores:
    """The GTSAM smoother's attitude at its keys (NaN between), scored like a filter;
    ``keep`` receives its attitude track at the keys."""
    M, every = log.n_epochs, world.epochs_per_key
    series = smooth_alignment(world, log)
    if keep is not None:
        keep[REFERENCE] = PoseTrack(np.array(log.times)[::every], None, series.q,
                                    series.cov_nav)
    err = np.full((M, 3), np.nan)
    cov = np.full((M, 3, 3), np.nan)
    idx = np.arange(0, M, every)
    e, c = misalignment_error(series.q, np.zeros_like(series.q), np.zeros((len(idx), 4, 4)),
                              log.truth_q[idx])
    err[idx], cov[idx] = e, series.cov_nav
    return _scores(REFERENCE, err, cov, np.full(M, np.nan), np.full(M, np.nan), 0,
                   series.time_s, len(idx) - 1, series.failure, world, series.marginals_failure)


@dataclass(frozen=True)
class AlignOutcome(RunOutcome):
    """A run's outcome and its share of the γ sweep (:mod:`slam.kinds.alignment.sweep`)."""

    sweep: tuple[SweepCell, ...] = ()


def run_once(world: AlignmentWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False, reference: bool = True
             ) -> RunOutcome:
    """Simulate run ``run`` from its own seed; score every filter and the smoother.

    With ``keep_tracks`` the tracks are the estimators' attitude tracks
    (:class:`~slam.results.PoseTrack`), ``truth`` the (M, 4) true attitude and ``times``
    the filter epochs.
    """
    log = simulate_alignment(world, np.random.default_rng(seed_seq))
    keep: dict[str, PoseTrack] | None = {} if keep_tracks else None
    scores = {n: run_filter(world, log, n, keep=keep) for n in filters}
    if reference and run < world.reference.runs:
        scores[REFERENCE] = run_reference(world, log, keep)
    cells = (sweep_run(world, log, np.array(log.times), run_filter)
             if run < world.sweep.runs else ())
    if not keep_tracks:
        return AlignOutcome(run, scores, sweep=cells)  # type: ignore[arg-type]
    return AlignOutcome(run, scores, keep, np.array(log.truth_q),  # type: ignore[arg-type]
                        None, np.array(log.times), sweep=cells)
