"""Report of an IMU + GNSS log run: the held-out / outage / NIS / CPU table of every
estimator (the filters, GTSAM online and smoothed), the settings used (the documented
default table for KITTI), warnings, and figures (:mod:`slam.kinds.ins_log.figures`).

Files: ``<estimator>.tum`` and ``<estimator>.cov.txt`` (:mod:`slam.render.tum`) of every
estimator: one pose per GNSS fix epoch from the alignment fix on (the filters' estimate
after the fix's update, or their prediction where the fix is withheld or dropped), the
IMU's position (not the antenna's) and ``q_nb`` in the log's navigation frame as read
(ENU, FLU body axes), ``t`` in seconds from the log's first IMU time stamp.  A log has no
true attitude, so no ``truth.tum``.  ``gtsam-online``'s sidecar rows are NaN except at
the scored fixes (its marginal at a later time is not that epoch's)."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam.kind import Deferred
from slam.kinds.ins_log.run import ONLINE
from slam.render import tum
from slam.render.decision import decision_sections, decision_text
from slam.render.document import KindReport, Section
from slam.render.tables import MISSING, estimator_entries, num, plain_table, wrap


def _outage_head(summary: dict[str, Any]) -> list[str]:
    return [f"drift {s:g}+{n:g} s\n(m)" for s, n in summary.get("outages") or []]


def _has_truth(summary: dict[str, Any]) -> bool:
    return any("truth" in e for _, e in estimator_entries(summary))


def columns(summary: dict[str, Any]) -> tuple[str, ...]:
    truth = ("truth\nRMSE (m)", "truth\nNEES/3") if _has_truth(summary) else ()
    return ("estimator", "held-out\nRMSE (m)", "held-out\nhoriz (m)", "held-out\nerr²/σ²",
            "NIS/dof", "NIS windows\nin 95 %", *_outage_head(summary), *truth, "CPU\n(s)",
            "diverged")


def _truth(e: dict[str, Any]) -> list[str]:
    t = e.get("truth")
    if t is None:
        return []
    return [num(t.get("rmse_m"), ".3f"), num(t.get("nees_per_dof"), ".2f")]


def _row(name: str, e: dict[str, Any]) -> list[str]:
    h = e.get("heldout") or {}
    nis = e.get("nis") or {}
    band = (f"{nis['inside']}/{nis['windows']}" if nis.get("windows") else MISSING)
    drifts = [num(o.get("drift_m"), ".2f") for o in e.get("outages") or []]
    return [name, num(h.get("rmse_m"), ".3f"), num(h.get("rmse_horizontal_m"), ".3f"),
            num(h.get("mean_normalised_error"), ".2f"), num(nis.get("mean_nis_per_dof"), ".2f"),
            band, *drifts, *_truth(e), num(e.get("cpu_s"), ".2f"),
            "yes" if e.get("diverged") else "no"]


def rows(summary: dict[str, Any]) -> list[list[str]]:
    return [_row(n, e) for n, e in estimator_entries(summary)]


def head(summary: dict[str, Any]) -> str:
    s = summary
    hold = (f"every {s['holdout']}th fix withheld, scored from fix {s['score_from_fix']}"
            if s.get("holdout") else "no fixes withheld (--holdout K)")
    line = (f"{s.get('log')}: {s.get('imu_readings')} IMU readings, {s.get('fixes')} GNSS "
            f"fixes over {num(s.get('duration_s'), '.1f')} s ({s.get('gaps_over_0_1_s')} "
            f"reading intervals over 0.1 s, held); {hold}.")
    best = s.get("best_filter_over_online")
    if best:
        line += (f" Best filter {best['filter']}: {best['ratio']:.2f}x GTSAM online's "
                 "held-out RMSE.")
    return line


def settings_lines(summary: dict[str, Any]) -> list[str]:
    st = summary.get("settings") or {}
    out = [f"Settings: {st.get('reading', '')}"]
    imu = st.get("imu") or {}
    if imu:
        out.append("IMU model (SI): " + ", ".join(
            f"{k} {v:.4g}" if isinstance(v, float | int) else f"{k} {v}" for k, v in imu.items()))
    k = st.get("preintegration_fixes")
    if k is not None:
        out.append(f"Prediction: the IMU increments of {k} epoch{'s' if k != 1 else ''} "
                   "preintegrated together about the filter mean's biases at the first "
                   "(preintegration_fixes; 1: each epoch about its own mean's)."
                   if k != 1 else "Prediction: each epoch preintegrated about its own "
                   "mean's biases (preintegration_fixes = 1).")
    for n, d in (st.get("filters") or {}).items():
        if d:
            out.append(f"{n}: {d}")
    if summary.get("alignment"):
        out.append(f"Alignment: {summary['alignment']}.")
    return out


def text_table(summary: dict[str, Any]) -> str:
    """The terminal table, the settings beside it and any warning lines."""
    notes = [*summary.get("warnings", []), *settings_lines(summary)]
    for n, e in estimator_entries(summary):
        if e.get("failure"):
            notes.append(f"{n}: {e['failure']}")
    cpu = summary.get("cpu_over_isam2")
    if cpu:
        notes.append("CPU / iSAM2 online: " + ", ".join(f"{n} {r:.2f}" for n, r in cpu.items()))
    return "\n".join([wrap(head(summary)), "", plain_table(columns(summary), rows(summary)),
                      *(wrap(n) for n in notes), "", decision_text(summary)])


HOW_TO_READ = (
    "A recorded log has no truth. `held-out` is the error of each estimator's position at "
    "the GNSS fixes withheld from all of them (the estimator's prediction there against the "
    "fix, which carries its own noise), `err²/σ²` its mean normalised square "
    "e'(P + R)^-1 e / 3 (1 when the estimator's covariance and the fix σ describe the "
    "error), `NIS/dof` the filters' mean normalised innovation and `NIS windows in 95 %` how "
    "many windows of 50 updates have their mean inside the 95 % band. `drift` is the error "
    "at the last fix of each GNSS outage. `gtsam-online` is iSAM2's estimate right after "
    "each fix (a filter's information), `gtsam` its smoothed estimate (all the fixes used). "
    "CPU is process time for the whole log (loaded machine).")


def _sections(summary: dict[str, Any]) -> list[Section]:
    notes = " ".join([*summary.get("warnings", []), *settings_lines(summary)])
    first, *rest = decision_sections(summary) or [None]
    return [s for s in (first, Section("Results", columns(summary), rows(summary),
                                       head(summary)), *rest,
                        Section("Settings and warnings", text=notes),
                        Section("How to read this", text=HOW_TO_READ)) if s is not None]


TUM_NOTE = ("x, y, z: the IMU's position (m) in the log's navigation frame, ENU; q = q_nb "
            "(body forward-left-up to ENU); one pose per GNSS fix epoch from the alignment "
            "fix on (after the fix's update; the prediction at a withheld or dropped fix); "
            "t from the log's first IMU time stamp")
TUM_COV = ("t, then the 6 x 6 covariance of [position (m, ENU), attitude rotation vector "
           "(rad, body frame: q = q̂ ⊗ Exp(δθ))] row-major")


def _online_cov(name: str) -> str:
    return TUM_COV + ("; NaN except at the scored (withheld or dropped) fixes: iSAM2's "
                      "marginal there, right after that fix" if name == ONLINE else "")


def _track(o: Any, name: str) -> tuple[Any, Any, Any]:
    tr = o.tracks[name]
    E = len(tr.p)
    q = np.full((E, 4), np.nan) if tr.q is None else tr.q
    return tr.p, q, tr.pose_cov


write_tum_files, tum_links = tum.report_files(_track, TUM_NOTE, _online_cov, "pose")
"""The TUM files and covariance sidecars of the log's estimators (module docstring) and the
report's entries for them."""


REPORT = KindReport("IMU + GNSS log run", _sections,
                    Deferred("slam.kinds.ins_log.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The IMU + GNSS log kind's report."""
