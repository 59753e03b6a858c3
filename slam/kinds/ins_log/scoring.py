r"""Scores of an IMU + GNSS log without truth: held-out fixes, outage drift, NIS windows.

Held-out fixes (``--holdout K``)
    At every withheld fix ``i`` from :data:`~slam.kinds.ins_log.world.SCORE_FROM` on, the
    estimator's position (its prediction: the fix was never used) against the fix:
    RMSE of :math:`e_i = \hat p_i - z_i` (3-D and horizontal), the largest, and the
    normalised error :math:`e_i^\top(P_i + R_i)^{-1}e_i/3` (mean; 1 when the estimator's
    covariance and the fix's σ describe the error).
Outages (``--outage START:LENGTH``)
    The error at the last fix inside each window (the drift after the window's length
    without GNSS), 3-D and horizontal, with the estimator's own σ there.
NIS per window
    The filters' NIS over consecutive windows of :data:`NIS_WINDOW` updates: each window's
    mean NIS / dof against the two-sided 95 % band of a mean of ``window · dof`` χ²
    degrees of freedom; :func:`nis_warning` words the verdict when most windows are
    outside (the noise is badly scaled, and which way).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slam.decision import decide
from slam.kinds.ins_log.run import DROPPED, ONLINE, SMOOTHED, WITHHELD, EstimatorTrack
from slam.kinds.ins_log.world import SCORE_FROM, Scoring
from slam.nulls import reason_key, unexplained_nulls
from slam.ranking import Metric
from slam.results import RunOutcome
from slam.scoring import chi2_ppf

NIS_WINDOW = 50
#: More than this fraction of the NIS windows outside the band: the warning line.
NIS_WARN_FRACTION = 0.5


def _f(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def heldout_indices(roles: np.ndarray) -> np.ndarray:
    idx = np.arange(len(roles))
    return idx[(roles == WITHHELD) & (idx >= SCORE_FROM)]


def outage_ends(fix_t: np.ndarray, t0: float, roles: np.ndarray, scoring: Scoring
                ) -> list[tuple[tuple[float, float], int | None]]:
    """Per outage window, the last fix inside it (``None`` if it holds none)."""
    out = []
    rel = fix_t - t0
    for start, length in scoring.outages:
        inside = np.flatnonzero((rel >= start) & (rel < start + length) & (roles == DROPPED))
        out.append(((start, length), int(inside[-1]) if len(inside) else None))
    return out


def nis_windows(nis: np.ndarray, dof: int, window: int = NIS_WINDOW) -> dict[str, Any]:
    """Mean NIS / dof per window of ``window`` updates and the band (module docstring)."""
    n = len(nis) // window
    if n == 0 or dof == 0:
        return {"windows": 0, "reason": f"fewer than {window} updates"}
    means = nis[: n * window].reshape(n, window).mean(axis=1) / dof
    k = window * dof
    lo, hi = float(chi2_ppf(0.025, k)) / k, float(chi2_ppf(0.975, k)) / k
    return {"windows": n, "window_updates": window, "band": [lo, hi],
            "mean_nis_per_dof": _f(float(np.mean(nis) / dof)),
            "per_window": [_f(m) for m in means],
            "inside": int(np.sum((means >= lo) & (means <= hi))),
            "above": int(np.sum(means > hi)), "below": int(np.sum(means < lo))}


def nis_warning(name: str, w: dict[str, Any]) -> str | None:
    """The warning line when most NIS windows are outside their band, else ``None``."""
    n = w.get("windows", 0)
    if not n or w["inside"] >= (1.0 - NIS_WARN_FRACTION) * n:
        return None
    way = ("too small: the filter is over-confident (noise under-stated)"
           if w["above"] >= w["below"] else
           "too large: the filter is under-confident (noise over-stated)")
    return (f"warning: {name}: NIS/dof in its 95 % band in {w['inside']} of {n} windows "
            f"(mean {w['mean_nis_per_dof']:.2f}, band {w['band'][0]:.2f}-{w['band'][1]:.2f}); "
            f"the stated noise looks {way}")


def truth_scores(truth: np.ndarray, tr: EstimatorTrack) -> dict[str, Any]:
    """With truth (the CSV's ``tx ty tz`` at the fixes): the position RMSE over every fix
    epoch with a true position, and the mean position NEES / 3 where the estimator has a
    covariance (the smoother only at the scored fixes)."""
    ok = np.all(np.isfinite(truth), axis=1) & np.all(np.isfinite(tr.p), axis=1)
    if not ok.any():
        return {"epochs": 0}
    e = tr.p[ok] - truth[ok]
    P = tr.P[ok]
    has = np.all(np.isfinite(P), axis=(1, 2))
    nees = [float(x @ np.linalg.solve(C, x)) / 3.0 for x, C in zip(e[has], P[has])]
    out = {"epochs": int(ok.sum()), "rmse_m": _f(float(np.sqrt(np.mean(np.sum(e**2, 1))))),
           "final_error_m": _f(float(np.linalg.norm(e[-1])))}
    out["nees_per_dof"] = _f(float(np.mean(nees))) if nees else None
    out["nees_epochs"] = len(nees)
    if not nees:
        out["nees_per_dof_reason"] = "no position covariance at these epochs"
    return out


def score_track(log: Any, tr: EstimatorTrack, a: int, roles: np.ndarray, scoring: Scoring
                ) -> dict[str, Any]:
    """One estimator's values (module docstring); positions are ``tr.p[i - a]``."""
    out: dict[str, Any] = {"cpu_s": tr.cpu_s, "diverged": tr.failure is not None}
    if tr.failure is not None:
        out["failure"] = tr.failure
    held = heldout_indices(roles)
    held = held[held >= a]
    if len(held):
        e = tr.at_fix[held - a] - log.fix_p[held]
        R = np.stack([np.diag(s**2) for s in log.fix_sp[held]])
        with np.errstate(invalid="ignore"):
            nees = np.array([float(x @ np.linalg.solve(C, x)) / 3.0 if np.all(np.isfinite(C))
                             else math.nan for x, C in zip(e, tr.P[held - a] + R)])
        d3, d2 = np.linalg.norm(e, axis=1), np.linalg.norm(e[:, :2], axis=1)
        out["heldout"] = {"fixes": int(len(held)), "from_fix": SCORE_FROM,
                          "rmse_m": _f(float(np.sqrt(np.mean(d3**2)))),
                          "rmse_horizontal_m": _f(float(np.sqrt(np.mean(d2**2)))),
                          "max_m": _f(float(np.max(d3))),
                          "mean_normalised_error": _f(float(np.mean(nees))),
                          "fix": held.tolist(), "error_m": [_f(x) for x in d3]}
    ends = []
    for (start, length), j in outage_ends(log.fix_t, log.t[0], roles, scoring):
        entry: dict[str, Any] = {"start_s": start, "length_s": length}
        if j is None or j < a:
            entry["reason"] = "no fix inside the window after the alignment"
        else:
            e = tr.at_fix[j - a] - log.fix_p[j]
            sig = float(np.sqrt(np.trace(tr.P[j - a]))) if np.all(np.isfinite(tr.P[j - a])) \
                else math.nan
            entry.update({"fix": j, "drift_m": _f(float(np.linalg.norm(e))),
                          "drift_horizontal_m": _f(float(np.linalg.norm(e[:2]))),
                          "sigma_m": _f(sig)})
        ends.append(entry)
    if ends:
        out["outages"] = ends
    if log.truth_p is not None:
        out["truth"] = truth_scores(log.truth_p[a:], tr)
    if tr.name not in (ONLINE, SMOOTHED):
        out["nis"] = nis_windows(tr.nis, tr.nis_dof)
    explain_nulls(out, f"not finite: the estimator failed ({tr.failure})" if tr.failure
                  else "not finite (no finite estimate or covariance there)")
    return out


def explain_nulls(table: dict[str, Any], why: str) -> None:
    """Give every null (or list or table holding one) in ``table`` and the tables below it
    a ``<key>_reason`` (:mod:`slam.nulls`) saying ``why``, unless it has one."""
    for key, value in list(table.items()):
        if isinstance(value, dict):
            explain_nulls(value, why)
        elif isinstance(value, list):
            for v in value:
                if isinstance(v, dict):
                    explain_nulls(v, why)
        if unexplained_nulls({key: value}) and reason_key(key) not in table \
                and not isinstance(value, dict):
            table[reason_key(key)] = why


def summary_of(world: Any, outcome: RunOutcome, filters: list[str], score_from: int
               ) -> dict[str, Any]:
    """The ``summary.json`` dict of a log run."""
    log = world.log
    s = log.settings
    sc = outcome.scores
    fl = world.filters
    warnings = [w for n in filters if n in sc
                for w in [nis_warning(n, sc[n].values.get("nis", {}))] if w]
    first = next(iter(sc.values()), None)
    out: dict[str, Any] = {
        "kind": world.kind, "world": world.name, "log": log.name, "source": log.source,
        "imu_readings": int(len(log.t)), "fixes": log.n_fixes,
        "duration_s": log.duration_s, "gaps_over_0_1_s": log.gaps,
        "fixes_outside_imu_span": log.dropped_fixes,
        "holdout": world.scoring.holdout, "score_from_fix": score_from,
        **({} if world.scoring.holdout else {"holdout_reason": "no --holdout K given"}),
        "outages": [list(o) for o in world.scoring.outages],
        "alignment": first.values.get("alignment") if first else None,
        "settings": {"reading": s.reading, "imu": s.psd.as_dict(),
                     "gnss_position_sigma_m": s.position_sigma_m,
                     "gravity_latitude_deg": math.degrees(s.latitude_rad),
                     "gravity_height_m": s.height_m, "earth_rate": s.earth_rate,
                     "preintegration_fixes": s.preintegration_fixes,
                     "filters": {n: fl.describe(n) for n in filters}},
        "filters": {n: sc[n].values for n in filters if n in sc},
        "reference": {n: sc[n].values for n in (ONLINE, SMOOTHED) if n in sc},
        "warnings": warnings,
    }
    if out["alignment"] is None:
        out["alignment_reason"] = "no estimator ran"
    best = [(v["heldout"]["rmse_m"], n) for n, v in out["filters"].items()
            if v.get("heldout", {}).get("rmse_m") is not None]
    online = out["reference"].get(ONLINE, {}).get("heldout", {}).get("rmse_m")
    if best and online:
        r, n = min(best)
        out["best_filter_over_online"] = {"filter": n, "ratio": r / online}
    cpu = out["reference"].get(ONLINE, {}).get("cpu_s")
    if cpu:
        out["cpu_over_isam2"] = {n: v["cpu_s"] / cpu for n, v in out["filters"].items()}
    return decide(out, metrics(sc), filters=[n for n in filters if n in sc], consistency=None,
                  reference=SMOOTHED, tuned=fl)


def _mse(values: dict[str, Any], key: str) -> float:
    """Mean squared position error of a score table's ``key`` block (held-out fixes:
    their per-fix errors; truth: its RMSE squared), NaN where there is none."""
    block = values.get(key) or {}
    if key == "heldout":
        e = np.array([x for x in block.get("error_m", []) if x is not None], dtype=float)
        return float(np.mean(e**2)) if e.size else float("nan")
    r = block.get("rmse_m")
    return float(r) ** 2 if r is not None else float("nan")


def metrics(scores: dict[str, Any]) -> list[Metric]:
    """The headline metrics of a log run (one run: ordered, never significant): the
    position MSE at the held-out fixes and, with truth, against it."""
    out = [Metric("heldout", "position at the held-out fixes", "m",
                  {n: np.array([_mse(s.values, "heldout")]) for n, s in scores.items()})]
    if any("truth" in s.values for s in scores.values()):
        out.append(Metric("truth", "position against the truth", "m",
                          {n: np.array([_mse(s.values, "truth")]) for n, s in scores.items()}))
    return out
