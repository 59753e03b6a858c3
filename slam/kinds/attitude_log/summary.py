"""The ``summary.json`` of a recorded attitude log: per estimator the attitude error
against the truth (RMS, after 10 s, final), the bias error, the attitude difference to
the smoother, ANEES with its one-run 95 % band and verdict, NIS per dof with its band,
wall and CPU time, the filters' settings, and the decision (:func:`slam.decision.decide`):
the filters ranked by their mean squared attitude error against the log's truth, over the
whole log and after the first 10 s - one log is one run, so no difference is called
significant."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from slam.decision import Consistency, decide
from slam.kinds.attitude_log.run import DEG, STEADY_FROM_S, AttitudeLogScores
from slam.kinds.attitude_log.world import KIND, AttitudeLogWorld
from slam.ranking import Metric, per_run
from slam.render.tables import verdict
from slam.results import REFERENCE, RunOutcome
from slam.scoring import anees_entries, nis_stats


def _rms_deg(err: np.ndarray) -> float:
    norm = np.linalg.norm(err, axis=1)
    norm = norm[np.isfinite(norm)]
    return float(np.sqrt(np.mean(norm**2)) / DEG) if norm.size else float("nan")


def entry(s: AttitudeLogScores, t: np.ndarray) -> dict[str, Any]:
    """One estimator's summary entry (module docstring); a diverged one says why."""
    out: dict[str, Any] = {"diverged": s.diverged}
    if s.diverged:
        out["failure"] = s.failure
        out["runs_scored"] = 0
        return out
    out["runs_scored"] = 1
    steady = t >= t[0] + STEADY_FROM_S
    att, bias = s.err[:, :3], s.err[:, 3:]
    out["att_rmse_deg"] = _rms_deg(att)
    out["att_rmse_after_10s_deg"] = _rms_deg(att[steady])
    why = f"the log ends before t = {STEADY_FROM_S:g} s" if not steady.any() else None
    if why:
        out["att_rmse_after_10s_deg_reason"] = why
    out["att_final_deg"] = float(np.linalg.norm(att[-1]) / DEG)
    out["bias_rmse_deg_s"] = float(np.sqrt(np.mean(np.sum(bias**2, axis=1))) / DEG)
    if np.isfinite(s.err_to_ref).any():
        out["att_rmse_to_smoother_deg"] = _rms_deg(s.err_to_ref)
        out["att_rmse_to_smoother_after_10s_deg"] = _rms_deg(s.err_to_ref[steady])
        if why:
            out["att_rmse_to_smoother_after_10s_deg_reason"] = why
    out.update(anees_entries(s.nees[None], 6, full=True))
    if "anees" in out:
        out["consistency"] = verdict(out) or "no NEES"
    st = nis_stats(s.nis, s.nis_dof)
    if st:
        out.update({"nis_per_dof": st["per_dof"], "nis_bounds_95": st["band"],
                    "nis_updates": st["updates"], "nis_updates_inside_95": st["inside"]})
    out["time_s"] = s.time_s
    out["cpu_s"] = s.cpu_s
    if s.extra_time_s:
        out["marginals_time_s"] = s.extra_time_s
    return out


def _mse_deg2(err: np.ndarray) -> float:
    return _rms_deg(err) ** 2


def metrics(outcomes: list[RunOutcome], names: list[str], t: np.ndarray) -> list[Metric]:
    """The headline metrics: per-run mean squared attitude error (deg²) against the
    truth over the whole log and from ``STEADY_FROM_S`` on."""
    steady = t >= t[0] + STEADY_FROM_S
    return [
        Metric("attitude", "attitude (whole log)", "deg", {
            n: per_run(outcomes, n, lambda s: _mse_deg2(s.err[:, :3])) for n in names}),
        Metric("attitude_after_10s", f"attitude (after {STEADY_FROM_S:g} s)", "deg", {
            n: per_run(outcomes, n, lambda s: _mse_deg2(s.err[steady, :3])) for n in names}),
    ]


def summarize(world: AttitudeLogWorld, outcomes: list[RunOutcome], filters: list[str],
              runs: int, seed: int) -> dict[str, Any]:
    """The ``summary.json`` dict of the run on a recorded attitude log."""
    log = world.log
    rows = log.epochs
    t = log.t[rows]
    scores = outcomes[0].scores
    fs = world.filters
    summary = {
        "world": world.name, "kind": KIND, "log": Path(log.source).name, "source": log.source,
        "rows": log.n_rows, "epochs": int(len(rows)), "duration_s": float(log.t[-1] - log.t[0]),
        "sensors": log.n_sensors,
        "readings_per_sensor": [int(n) for n in log.seen.sum(axis=0)],
        "gyro_arw_rad_sqrt_s": log.arw.tolist(), "gyro_bias_rw_rad_s_sqrt_s": log.bias_rw.tolist(),
        "initial_belief": {"attitude": "identity", "bias_rad_s": [0.0, 0.0, 0.0],
                           "attitude_var_rad2": fs.initial_attitude_var_rad2,
                           "bias_var_rad2_s2": fs.initial_bias_var_rad2_s2},
        "steady_from_s": STEADY_FROM_S,
        "nis_dof_note": "2 dof per unit reading (its radial component carries no noise)",
        "filters": {n: entry(scores[n], t) for n in filters},
        "reference": {REFERENCE: entry(scores[REFERENCE], t)},
    }
    return decide(summary, metrics(outcomes, [*filters, REFERENCE], t), filters=filters,
                  consistency=Consistency(label="attitude + bias (6-dof)"),
                  tuned=fs)
