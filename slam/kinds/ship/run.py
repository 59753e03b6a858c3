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
from typing import Any

import numpy as np

from estimators import Measurement, Transition, make_filter
from estimators.loop import BeliefRecorder, run_epochs
from estimators.models import Belief
from nav.euler import euler_zyx_to_q, q_to_euler_zyx
from slam.failures import run_reference
from slam.kinds.ship.models import (
    Treatment,
    earth_rate_transition,
    label,
    treatment,
    vector_measurement,
)
from slam.kinds.ship.reference import smooth_ship
from slam.kinds.ship.scoring import paired_mse, score, summarize_scores
from slam.kinds.ship.simulate import ShipLog, simulate_ship
from slam.kinds.ship.world import ShipWorld
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
"""Paired comparisons ``(a, b, what differs)`` made when both estimators ran."""


def initial_belief(world: ShipWorld, log: ShipLog) -> tuple[Array, Array]:
    """``(x0, P0)``: the truth's Z-Y-X angles at t = 0 plus the world's initial error, zero
    drift; ``P0 = diag(σ_att², σ_α² I)`` in the tangent (body-frame) coordinates."""
    fs = world.filters
    e = q_to_euler_zyx(log.truth_q[0]) + np.asarray(fs.initial_error_rad)
    x0 = np.concatenate([euler_zyx_to_q(*e), np.zeros(3)])
    P0 = np.diag(np.concatenate([np.square(fs.initial_attitude_sigma_rad),
                                 np.full(3, fs.initial_bias_sigma_rad_s**2)]))
    return x0, P0


def run_filter(log: ShipLog, name: str, treat: Treatment, x0: Array, P0: Array,
               transition: Transition, vector_model: Measurement, main: bool = True
               ) -> EstimateSeries:
    """Filter ``name`` with treatment ``treat`` over the log (module docstring)."""
    flt = make_filter(name)
    M = log.n_updates
    rec = BeliefRecorder.empty(M, 7, 6)
    dof: list[int] = []

    def correct(j: int, belief: Belief) -> tuple[Belief, list]:
        model, z = treat.measurement(belief, log, j, vector_model)
        post, innovation = flt.update(belief, model, z)
        dof.append(model.noise.dim)
        return post, [innovation]

    out = run_epochs(flt, flt.init(x0, treat.space, cov=P0), M, correct_first=True,
                     transition=lambda j, b: (transition, log.gyro_block(j - 1)),
                     correct=correct, record=rec)
    nis = np.full(M, np.nan)
    nis[out.nis_epoch] = out.nis
    return EstimateSeries(label(name, treat.name, main), rec.means, rec.covs, M - 1, nis=nis,
                          nis_dof=dof[0] if dof else 0, time_s=out.time_s,
                          diverged=out.diverged, failure=out.failure)


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
    series = [run_filter(log, n, treatment(t), x0, P0, trans, vec, main)
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


def summarize(world: ShipWorld, outcomes: list[RunOutcome], filters: list[str], runs: int,
              seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of a ship campaign (keys explained in the report)."""
    times = np.arange(world.n_updates) / world.vectors.rate_hz
    sc = world.scoring

    def entry(name: str) -> dict[str, Any]:
        scores = [o.scores[name] for o in outcomes if name in o.scores]
        return summarize_scores(scores, times, sc.steady_state_from_s, sc.converge_rad)

    runs_made = estimators(world, filters)
    names = {label(n, t, m): (n, t, m) for n, t, m in runs_made}
    reference = {}
    if any(REFERENCE in o.scores for o in outcomes):
        reference = {REFERENCE: entry(REFERENCE)}
        for key in ("time_per_cycle_s", "time_per_run_s"):
            reference[REFERENCE].pop(key, None)
        good = [o.scores[REFERENCE] for o in outcomes if REFERENCE in o.scores]
        reference[REFERENCE]["time_s"] = float(np.mean([s.time_s for s in good]))
        reference[REFERENCE]["marginals_time_s"] = float(np.mean([s.extra_time_s
                                                                  for s in good]))
    steady = times >= sc.steady_state_from_s
    comparisons = []
    for a, b, what in COMPARISONS:
        if a in names and b in names:
            pa, pb = ([o.scores[k] for o in outcomes] for k in (a, b))
            comparisons.append({"a": a, "b": b, "what": what, **paired_mse(pa, pb, steady)})
    return {
        "world": world.name, "kind": world.kind, "runs": runs, "seed": seed,
        "update_rate_hz": world.vectors.rate_hz, "gyro_rate_hz": world.gyro.rate_hz,
        "duration_s": world.duration_s,
        "steady_state_window_s": [sc.steady_state_from_s, world.duration_s],
        "converge_bound_arcmin": sc.converge_rad / (np.pi / 180.0 / 60.0),
        "euler_sequence": "Z-Y-X (yaw, pitch, roll); body forward-left-up, navigation ENU",
        "filters": {n: {**entry(n), "treatment": names[n][1]} for n in filters},
        "variants": {k: {**entry(k), "filter": v[0], "treatment": v[1]}
                     for k, v in names.items() if not v[2]},
        "treatments": DESCRIPTIONS,
        "comparisons": comparisons,
        "reference": reference,
        "paper": world.paper,
    }
