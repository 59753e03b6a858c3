r"""Ship SINS attitude ([Ding 2017]): one Monte Carlo run and the campaign summary.

Every run simulates the log once (:mod:`slam.kinds.ship.simulate`) and runs on it

* the world's filters (``[filters] names``), each from :func:`estimators.make_filter`:
  those in ``paper_model`` with the paper's treatment (pseudo-observation + eigenvector
  mean), the others with the ``manifold`` treatment (plain vector measurement, chart
  mean; ``ekf`` there is the multiplicative EKF);
* the effect variants (``[filters] variants``, ``"filter:treatment"``) whose filter is
  among the run's filters, for the table that separates the effects;
* the GTSAM smoother (:mod:`slam.kinds.ship.reference`).

All of them see the same log, start from the same belief and use the same process model
(:mod:`slam.kinds.ship.models`).  Every filter epoch is one vector interval: a
prediction through its gyro samples, then one batch update with both vectors; the first
update is at t = 0.  Numerical failures end a run as diverged (the one filter loop,
:func:`estimators.loop.run_epochs`) and are counted with their reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import Filter, Measurement, Transition
from estimators.loop import BeliefRecorder, run_epochs
from estimators.models import Belief
from nav.euler import euler_zyx_to_q, q_to_euler_zyx
from slam.decision import Consistency, decide
from slam.failures import run_reference
from slam.kinds.ship.models import (
    Treatment,
    earth_rate_transition,
    label,
    treatment,
    vector_measurement,
)
from slam.kinds.ship.reference import smooth_ship
from slam.kinds.ship.scoring import ARCMIN, homm_moments, score, summarize_scores
from slam.kinds.ship.simulate import ShipLog, simulate_ship
from slam.kinds.ship.world import ShipWorld
from slam.ranking import Metric, paired, per_run, per_run_mse
from slam.results import REFERENCE, Array, EstimateSeries, RunOutcome

DESCRIPTIONS = {
    "paper": "pseudo-observation Z = G q (noise separation) + eigenvector (Lagrange) mean",
    "additive": "pseudo-observation Z = G q + additive (renormalised weighted-sum) mean",
    "chart": "pseudo-observation Z = G q + iterative q ⊗ Exp(δ) chart mean",
    "manifold": "vector measurement B = C(q)ᵀ R + iterative q ⊗ Exp(δ) chart mean",
}

COMPARISONS = (
    ("hommukf", "ukf", "point rule: HoMM vs unscented (paper's model)"),
    ("hommukf", "cdkf", "point rule: HoMM vs central difference (paper's model)"),
    ("ukf:additive", "ukf", "quaternion mean: additive vs eigenvector"),
    ("ukf:chart", "ukf", "quaternion mean: chart vs eigenvector"),
    ("ukf", "ukf:manifold", "paper's model vs manifold treatment (UKF)"),
    ("ukf:chart", "ukf:manifold", "measurement: Z = G q vs B = C(q)ᵀR (chart mean)"),
    ("hommukf", "srckf", "HoMM-UKF (paper's model) vs SRCKF (manifold)"),
    ("hommukf", "ekf", "HoMM-UKF (paper's model) vs MEKF"),
)
"""Paired comparisons ``(a, b, what differs)`` made when both estimators ran (the effects
of the quaternion mean and the measurement model are between variants, which the ranking
of the main filters does not compare)."""

CONSISTENCY = Consistency("anees", "anees_bounds_95", "anees_inside_95", "anees_above_95",
                          "attitude and drift (6-dof)")
"""The headline consistency score of a ship entry (:func:`slam.kinds.ship.scoring.
summarize_scores`)."""


@dataclass(frozen=True)
class ShipSeries(EstimateSeries):
    """An :class:`~slam.results.EstimateSeries` with, for a HoMM filter with predicted
    moments, ``moments`` (M, 3): per epoch the skewness and kurtosis its update drew with
    and 1.0 where the estimate was refused (NaN where none, e.g. epoch 0)."""

    moments: Array | None = None


def _moment_row(belief: Belief) -> Array:
    m = getattr(belief, "moments", None)
    if m is None:
        return np.full(3, np.nan)
    return np.array([m.skewness, m.kurtosis, 0.0 if m.fallback is None else 1.0])


def initial_belief(world: ShipWorld, log: ShipLog) -> tuple[Array, Array]:
    """``(x0, P0)``: the truth's Z-Y-X angles at t = 0 plus the world's initial error, zero
    drift; ``P0 = diag(σ_att², σ_α² I)`` in the tangent (body-frame) coordinates."""
    fs = world.filters
    e = q_to_euler_zyx(log.truth_q[0]) + np.asarray(fs.initial_error_rad)
    x0 = np.concatenate([euler_zyx_to_q(*e), np.zeros(3)])
    P0 = np.diag(np.concatenate([np.square(fs.initial_attitude_sigma_rad),
                                 np.full(3, fs.initial_bias_sigma_rad_s**2)]))
    return x0, P0


def run_filter(log: ShipLog, flt: Filter, treat: Treatment, x0: Array, P0: Array,
               transition: Transition, vector_model: Measurement, main: bool = True
               ) -> EstimateSeries:
    """Filter ``flt`` (built with the world's settings) with treatment ``treat`` over the
    log (module docstring)."""
    name = flt.name
    M = log.n_updates
    rec = BeliefRecorder.empty(M, 7, 6)
    moments = np.full((M, 3), np.nan)
    dof: list[int] = []

    def record(e: int, belief: Belief) -> None:
        rec(e, belief)
        moments[e] = _moment_row(belief)

    def correct(j: int, belief: Belief) -> tuple[Belief, list]:
        model, z = treat.measurement(belief, log, j, vector_model)
        post, innovation = flt.update(belief, model, z)
        dof.append(model.noise.dim)
        return post, [innovation]

    out = run_epochs(flt, flt.init(x0, treat.space, cov=P0), M, correct_first=True,
                     transition=lambda j, b: (transition, log.gyro_block(j - 1)),
                     correct=correct, record=record)
    nis = np.full(M, np.nan)
    nis[out.nis_epoch] = out.nis
    return ShipSeries(label(name, treat.name, main), rec.means, rec.covs, M - 1, nis=nis,
                      nis_dof=dof[0] if dof else 0, time_s=out.time_s,
                      diverged=out.diverged, failure=out.failure,
                      moments=moments if np.isfinite(moments).any() else None)


def estimators(world: ShipWorld, filters: Sequence[str]) -> list[tuple[str, str, bool]]:
    """``(filter, treatment, main)`` of every estimator a run makes for ``filters``."""
    fs = world.filters
    main = [(n, fs.treatment(n), True) for n in filters]
    extra = [(n, t, False) for n, t in fs.variants if n in filters and (n, t) not in
             {(m, mt) for m, mt, _ in main}]
    return main + extra


def run_once(world: ShipWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: Sequence[str], keep_tracks: bool = False, reference: bool = True
             ) -> RunOutcome:
    """Simulate run ``run`` from its own seed; score every estimator and the smoother.

    With ``keep_tracks`` the tracks are the :class:`EstimateSeries` themselves, ``truth``
    is (M, 10) ``[q, α, roll, pitch, yaw]`` and ``times`` the vector epochs.
    """
    log = simulate_ship(world, np.random.default_rng(seed_seq))
    x0, P0 = initial_belief(world, log)
    g = world.gyro
    trans = earth_rate_transition(log.samples_per_update, log.dt, g.arw_rad_sqrt_s,
                                  g.bias_rw_rad_s_sqrt_s, log.earth_rate)
    vec = vector_measurement(log)
    series = [run_filter(log, world.filters.make(n), treatment(t), x0, P0, trans, vec, main)
              for n, t, main in estimators(world, filters)]
    if reference:
        ref, failure = run_reference(smooth_ship, log, x0, P0, g.arw_rad_sqrt_s,
                                     g.bias_rw_rad_s_sqrt_s)
        M = log.n_updates  # a smoother failure: no estimate, diverged with its reason
        series.append(ref or EstimateSeries(
            REFERENCE, np.full((M, 7), np.nan), np.full((M, 6, 6), np.nan), M - 1,
            nis=np.full(M, np.nan), nis_dof=0, time_s=0.0, diverged=True, failure=failure))
    scores = {s.name: score(s, log, world.scoring.divergence_rad) for s in series}
    if not keep_tracks:
        return RunOutcome(run, scores)
    idx = log.update_index
    truth = np.hstack([log.truth_q[idx], log.truth_bias[idx], log.euler[idx]])
    return RunOutcome(run, scores, {s.name: s for s in series},  # type: ignore[dict-item]
                      truth, None, np.array(log.update_times))


def metrics(world: ShipWorld, outcomes: list[RunOutcome], names: Sequence[str]
            ) -> list[Metric]:
    """The headline metrics (arcmin): the per-run attitude MSE (roll² + pitch² + yaw²) over
    the steady-state window, where the paper's bounds are, and over the whole run, which
    holds the convergence from the initial error; ``names`` are ranked (the smoother too,
    as the reference)."""
    times = np.arange(world.n_updates) / world.vectors.rate_hz
    steady = times >= world.scoring.steady_state_from_s

    def mse(epochs: Array | None) -> Any:
        return lambda s: float(per_run_mse(s.err[None], epochs)[0]) / ARCMIN**2

    return [Metric("attitude_steady", "attitude, steady state", "′",
                   {n: per_run(outcomes, n, mse(steady)) for n in names}),
            Metric("attitude", "attitude, whole run", "′",
                   {n: per_run(outcomes, n, mse(None)) for n in names})]


def _holds(p: dict[str, Any]) -> str:
    """Whether ``a`` beats ``b`` as the paper says, at 2 s.e. of the paired difference."""
    if p.get("se") is None:
        return "no standard error"
    if p["mean"] + 2.0 * p["se"] < 0.0:
        return "yes"
    return "reversed" if p["mean"] - 2.0 * p["se"] > 0.0 else "not distinguishable"


def paper_ordering(order: Sequence[str], heads: Sequence[Metric]) -> dict[str, Any]:
    """The paper's ordering (best first, ``[paper] ordering``) tested pair by pair on every
    headline metric: the paired per-run MSE difference ``a - b`` (:func:`slam.ranking.
    paired`) of each pair ``a`` before ``b``, whether ``a`` is better at 2 s.e. and its
    z; per metric ``reproduced``: ``yes`` when every pair holds, ``no`` when one is
    reversed, ``partly`` when some hold and the others are not distinguishable,
    ``unresolved`` when none is distinguishable."""
    order = [n for n in order if all(n in m.per_run_mse for m in heads)]
    out: dict[str, Any] = {"order": order, "pairs": [], "reproduced": {}}
    for m in heads:
        verdicts = []
        for i, a in enumerate(order):
            for b in order[i + 1:]:
                p = paired(m.per_run_mse[a], m.per_run_mse[b])
                z = p["mean"] / p["se"] if p.get("se") else None
                verdicts.append(_holds(p))
                out["pairs"].append({"metric": m.key, "a": a, "b": b, **p, "z": z,
                                     "holds": verdicts[-1]})
        out["reproduced"][m.key] = (
            "yes" if verdicts and all(v == "yes" for v in verdicts)
            else "no" if "reversed" in verdicts
            else "partly" if "yes" in verdicts else "unresolved")
    return out


def coincidence(outcomes: list[RunOutcome], names: Sequence[str]) -> dict[str, Any]:
    """How far apart the curves of ``convergence.png`` are: the largest difference over
    epochs and axes of two estimators' median |error| over the runs (arcmin), per pair
    of ``names`` (the paper-model filters), and the largest of all."""
    med = {}
    for n in names:
        errs = [o.scores[n].err for o in outcomes if n in o.scores and not o.scores[n].diverged]
        if errs:
            med[n] = np.nanmedian(np.abs(np.stack(errs)), axis=0) / ARCMIN
    pairs = [{"a": a, "b": b, "max_arcmin": float(np.nanmax(np.abs(med[a] - med[b])))}
             for i, a in enumerate(med) for b in list(med)[i + 1:]]
    out: dict[str, Any] = {"pairs": pairs,
                           "max_arcmin": max((p["max_arcmin"] for p in pairs), default=None)}
    if not pairs:
        out["max_arcmin_reason"] = (f"{len(med)} paper-model filter(s) with a finished run: "
                                    "no pair of curves to compare")
    return out


def summarize(world: ShipWorld, outcomes: list[RunOutcome], filters: list[str], runs: int,
              seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a ship campaign (keys explained in the report): the
    entries, the paired ranking by :func:`metrics` and the headline
    (:func:`slam.decision.decide`), the effects' paired comparisons."""
    times = np.arange(world.n_updates) / world.vectors.rate_hz
    sc = world.scoring

    def entry(name: str) -> dict[str, Any]:
        scores = [o.scores[name] for o in outcomes if name in o.scores]
        out = summarize_scores(scores, times, sc.steady_state_from_s, sc.converge_rad)
        moments = homm_moments(scores, times)
        return {**out, "homm_moments": moments} if moments else out

    runs_made = estimators(world, filters)
    names = {label(n, t, m): (n, t, m) for n, t, m in runs_made}
    reference = {}
    has_ref = any(REFERENCE in o.scores for o in outcomes)
    if has_ref:
        reference = {REFERENCE: entry(REFERENCE)}
        for key in ("time_per_cycle_s", "time_per_run_s"):
            reference[REFERENCE].pop(key, None)
        good = [o.scores[REFERENCE] for o in outcomes if REFERENCE in o.scores]
        reference[REFERENCE]["time_s"] = float(np.mean([s.time_s for s in good]))
        reference[REFERENCE]["marginals_time_s"] = float(np.mean([s.extra_time_s
                                                                  for s in good]))
    heads = metrics(world, outcomes, [*names, *([REFERENCE] if has_ref else [])])
    steady = heads[0].per_run_mse
    comparisons = []
    for a, b, what in COMPARISONS:
        if a in names and b in names:
            comparisons.append({"a": a, "b": b, "what": what, **paired(steady[a], steady[b])})
    summary = {
        "world": world.name, "kind": world.kind, "runs": runs, "seed": seed,
        "update_rate_hz": world.vectors.rate_hz, "gyro_rate_hz": world.gyro.rate_hz,
        "duration_s": world.duration_s,
        "steady_state_window_s": [sc.steady_state_from_s, world.duration_s],
        "converge_bound_arcmin": sc.converge_rad / (np.pi / 180.0 / 60.0),
        "euler_sequence": "Z-Y-X (yaw, pitch, roll); body forward-left-up, navigation ENU",
        "filters": {n: {**entry(n), "treatment": names[n][1]} for n in filters},
        "variants": {k: {**entry(k), "filter": v[0], "treatment": v[1],
                         "settings_text": world.filters.describe(v[0])}
                     for k, v in names.items() if not v[2]},
        "treatments": DESCRIPTIONS,
        "comparisons": comparisons,
        "paper_ordering": paper_ordering(world.paper.get("ordering") or [], heads),
        "coincidence": coincidence(outcomes, [n for n in filters
                                              if world.filters.treatment(n) == "paper"]),
        "reference": reference,
        "paper": world.paper,
    }
    fs = world.filters
    return decide(summary, heads, filters=filters, consistency=CONSISTENCY,
                  tuned=fs)
