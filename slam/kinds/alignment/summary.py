"""The ``summary.json`` of an alignment campaign ([Wu-Wang 2014]): every estimator's
Monte Carlo entry, the H∞ existence failures, the γ sweep, and the decision
(:func:`slam.decision.decide`): the paired ranking of the filters by the per-run MSE of
the level (East, North) misalignment and, apart, of the azimuth, over the settled epochs
(``[scoring] settled_from_s`` on, the paper's "settled within 50 s"), with the GTSAM
smoother as the reference and the level-axes ANEES as the consistency score."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam.decision import Consistency, decide
from slam.kinds.alignment.scoring import limits, summarize_scores
from slam.kinds.alignment.sweep import mse_arcmin, settled, summarize_sweep
from slam.kinds.alignment.world import HINF_NAMES, AlignmentWorld
from slam.ranking import Metric, ordering, per_run
from slam.results import REFERENCE, RunOutcome

PAPER_ORDER = ("uthinf", "ukf")
"""[Wu-Wang 2014] §4: the UT-H∞ filter aligns better than the UKF (whose East error
diverges under the low-frequency wind)."""

LEVEL = Consistency("anees_level", "anees_level_bounds_95", "anees_level_steps_inside_95",
                    "anees_level_steps_above_95", "level (East, North) misalignment")
"""The headline consistency score: the 2-dof NEES of the level axes (the 3-dof one is
the unobservable azimuth's, see the report)."""


def fallbacks(scores: list[Any]) -> dict[str, Any]:
    """H∞ existence failures (Kalman updates taken) over every run of one filter."""
    falls = [s.fallbacks for s in scores]
    updates = sum(s.updates for s in scores)
    return {"hinf_fallbacks": int(sum(falls)), "hinf_updates": int(updates),
            "hinf_runs_with_fallbacks": int(sum(f > 0 for f in falls))}


def metrics(world: AlignmentWorld, outcomes: list[RunOutcome], names: list[str],
            times: np.ndarray) -> list[Metric]:
    """The headline metrics: per-run MSE (arcmin²) of the level error norm and of the
    azimuth error over the settled epochs."""
    mask = settled(times, world.scoring.settled_from_s)
    return [Metric("level", "level (East, North) misalignment, settled", "′",
                   {n: per_run(outcomes, n, lambda s: mse_arcmin(s.err[:, :2], mask))
                    for n in names}),
            Metric("azimuth", "azimuth misalignment, settled", "′",
                   {n: per_run(outcomes, n, lambda s: mse_arcmin(s.err[:, 2:], mask))
                    for n in names})]


def summarize(world: AlignmentWorld, outcomes: list[RunOutcome], filters: list[str],
              runs: int, seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of an alignment campaign (keys explained in the report)."""
    times = np.arange(world.n_epochs) / world.filters.rate_hz
    factor = world.scoring.settle_factor

    def entry(name: str) -> dict[str, Any]:
        scores = [o.scores[name] for o in outcomes if name in o.scores]
        out = summarize_scores(scores, times, factor)
        if name in HINF_NAMES:
            out.update(fallbacks(scores))
        return out

    reference = ({REFERENCE: entry(REFERENCE)}
                 if any(REFERENCE in o.scores for o in outcomes) else {})
    w, fs = world.wind, world.filters
    summary: dict[str, Any] = {
        "world": world.name, "kind": world.kind, "runs": runs, "seed": seed,
        "filter_rate_hz": fs.rate_hz, "imu_rate_hz": world.imu.rate_hz,
        "duration_s": world.duration_s, "gamma": fs.gamma,
        "on_failure": (fs.hinf or {}).get("on_failure"),
        "settle_factor": factor, "settled_from_s": world.scoring.settled_from_s,
        "reference_runs": min(runs, world.reference.runs),
        "low_frequency_wind_mps": [w.amplitude_x_mps[2], w.amplitude_y_mps[2]],
        "compliance_m_per_mps": w.compliance_m_per_mps,
        "velocity_sigma_mps": fs.velocity_sigma_mps,
        "initial_misalignment_deg": np.degrees(fs.initial_misalignment_rad).tolist(),
        "axes": "East, North, azimuth (Up): residual misalignment Log(q_est ⊗ q_true*)",
        "limits": limits(world),
        "filters": {n: entry(n) for n in filters},
        "reference": reference,
        "paper": world.paper,
    }
    if world.sweep.runs and world.sweep.filters and world.sweep.gammas:
        summary["gamma_sweep"] = summarize_sweep(world, outcomes, times)
    ms = metrics(world, outcomes, [*filters, REFERENCE], times)
    if all(n in filters for n in PAPER_ORDER):
        summary["paper_ordering"] = [ordering(ms[0], *PAPER_ORDER)]
    return decide(summary, ms, filters=filters, consistency=LEVEL,
                  tuned=fs)
