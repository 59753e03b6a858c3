"""Tables and sections of an ``alignment`` campaign report ([Wu-Wang 2014]), from the
summary dict.

* Decision - the headline, the paired rankings (level and azimuth, settled epochs) and
  every filter's settings (:mod:`slam.render.decision`);
* The paper's ordering, tested - UT-H∞ against the UKF, paired;
* Results - every filter and the smoother: final East / North / azimuth error (RMS over
  the runs), settling times, the East error's RMS per quarter of the run and its trend,
  ANEES with its band and verdict, H∞ existence failures, timing (filters per cycle, every
  estimator per run);
* γ sweep - each H∞ filter at every γ: existence failures, errors, paired ΔMSE against
  its Kalman twin;
* Paper vs ours - the paper's H∞ numbers and its UKF claim beside ours;
* Theoretical limits - the level and azimuth limits from the world's sensor numbers;
* How to read this.

Files: ``truth.tum`` and ``<estimator>.tum`` with ``<estimator>.cov.txt`` of every tracked
run (run 0; every run with ``slam run --tum all``: :mod:`slam.render.tum`): attitude only
(zero position), the filters' corrected attitude at every filter epoch, the smoother's at
its keys.

Figures are in :mod:`slam.kinds.alignment.figures`; :data:`REPORT` is the kind's
:class:`~slam.render.document.KindReport`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from slam.kind import Deferred
from slam.render import tables, tum
from slam.render.decision import decision_sections, decision_text, ordering_section
from slam.render.document import KindReport, Section
from slam.results import REFERENCE

AXES = ("east", "north", "azimuth")


def _axis(e: dict[str, Any], key: str, axis: str, fmt: str = ".2f") -> str:
    return tables.num((e.get(key) or {}).get(axis), fmt)


def _windows(e: dict[str, Any], axis: str = "east") -> str:
    vals = (e.get("rms_window_arcmin") or {}).get(axis) or []
    return " / ".join(tables.num(v, ".2f") for v in vals) or tables.MISSING


def _cycle(name: str, e: dict[str, Any]) -> str:
    """A filter's time per predict + update cycle (the smoother has no cycles: its cost
    is per run)."""
    if name == REFERENCE:
        return "per run only"
    return tables.num(e.get("time_per_cycle_s"), ".2f", 1e3)


def fallback_cell(e: dict[str, Any]) -> str:
    """``"3/20010 (1 run)"``: H∞ existence failures among the updates (H∞ filters)."""
    if "hinf_fallbacks" not in e:
        return ""
    runs = e.get("hinf_runs_with_fallbacks", 0)
    return (f"{e['hinf_fallbacks']}/{e['hinf_updates']}"
            + (f" ({runs} run{'s' if runs != 1 else ''})" if runs else ""))


RESULT_HEADER = ("estimator", "final E (′)", "final N (′)", "final az (′)", "settle E (s)",
                 "settle N (s)", "E RMS by quarter (′)", "E trend (′/100 s)",
                 "ANEES [95 % band]", "in band", "verdict", "ANEES level (E, N)",
                 "ANEES 13-dof", "NIS/dof", "H∞ fallbacks",
                 "ms/cycle", "s/run", "diverged")


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter and the smoother (columns :data:`RESULT_HEADER`)."""
    return [[name, *(_axis(e, "final_rms_arcmin", a) for a in AXES),
             _axis(e, "settle_s", "east", ".1f"), _axis(e, "settle_s", "north", ".1f"),
             _windows(e), tables.num(e.get("east_trend_arcmin_per_100s"), "+.2f"),
             tables.anees_cell(e),
             tables.percent(e.get("anees_steps_inside_95")), tables.verdict(e) or tables.MISSING,
             tables.anees_cell(e, "anees_level", "anees_level_bounds_95"),
             tables.anees_cell(e, "anees_state", "anees_state_bounds_95"),
             tables.num(e.get("nis_mean"), ".2f"), fallback_cell(e), _cycle(name, e),
             tables.num(e.get("time_per_run_s"), ".2f"), tables.diverged_cell(e)]
            for name, e in tables.estimator_entries(summary)]


SWEEP_HEADER = ("filter", "γ", "runs", "fallbacks / updates", "runs with fallbacks",
                "diverged", "level RMSE (′)", "azimuth RMSE (′)", "final E / N / az (′)",
                "level ΔMSE vs twin (′²)", "z")


def _vs_twin(row: dict[str, Any]) -> tuple[str, str]:
    d = row.get("vs_twin")
    if not d:
        return tables.MISSING, tables.MISSING
    if d.get("se") is None:
        runs = d.get("runs", 0)
        return f"{tables.num(d.get('mean'), '+.3g')} ({runs} paired runs)", tables.MISSING
    z = d["mean"] / d["se"] if d["se"] > 0 else None
    return (f"{d['mean']:+.3g} ± {d['se']:.2g} vs {d['twin']}",
            tables.num(z, "+.1f") if z is not None else "all equal")


def sweep_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per (H∞ filter, γ) of the summary's ``gamma_sweep``."""
    out = []
    for r in (summary.get("gamma_sweep") or {}).get("rows") or []:
        fin = r.get("final_rms_arcmin") or {}
        out.append([r["filter"], r["gamma_text"], str(r["runs"]),
                    f"{r['fallbacks']}/{r['updates']}", str(r["runs_with_fallbacks"]),
                    str(r["diverged"]), tables.num(r.get("level_rmse_arcmin"), ".3f"),
                    tables.num(r.get("azimuth_rmse_arcmin"), ".1f"),
                    " / ".join(tables.num(fin.get(a), ".2f") for a in AXES), *_vs_twin(r)])
    return out


def sweep_text(summary: dict[str, Any]) -> str:
    sw = summary.get("gamma_sweep") or {}
    return (f"Each H∞ filter at every γ on the first {sw.get('runs', '?')} runs' logs, "
            f"on_failure = \"{sw.get('on_failure', 'kalman')}\": an update whose Riccati "
            "existence condition λmax(P_KF) < γ² fails takes the Kalman update for that step "
            "and is counted (fallbacks / updates; runs with any). RMSE over the settled epochs "
            f"(from {tables.num(sw.get('settled_from_s'), 'g')} s); final: RMS over the runs "
            "at the last epoch. ΔMSE vs twin: the paired per-run level MSE difference against "
            "the filter's γ = ∞ Kalman twin (uthinf: ukf, srchinf: srckf) on the same runs; "
            "negative: the H∞ bound helps.")


CLAIM_HEADER = ("filter", "paper", "ours", "holds")


def _ratio(ours: Any, paper: float) -> str:
    """``"no: ours 12× smaller"``, or ``"about equal"`` within 20 %."""
    if not isinstance(ours, int | float) or not ours > 0:
        return tables.MISSING
    r = ours / paper
    if 1 / 1.2 <= r <= 1.2:
        return "about equal"
    return f"no: ours {1 / r:.1f}× smaller" if r < 1 else f"no: ours {r:.1f}× larger"


def _claims_uthinf(c: dict[str, Any], e: dict[str, Any]) -> list[list[str]]:
    rows = []
    for axis, key in (("east", "east_final_arcmin"), ("north", "north_final_arcmin")):
        if isinstance(c.get(key), int | float):
            ours = (e.get("final_rms_arcmin") or {}).get(axis)
            rows.append(["uthinf", f"final {axis} error {c[key]:g}′",
                         f"{tables.num(ours, '.2f')}′ (RMS over runs)", _ratio(ours, c[key])])
    if isinstance(c.get("settle_within_s"), int | float):
        st = [(e.get("settle_s") or {}).get(a) for a in ("east", "north")]
        ok = all(isinstance(v, int | float) for v in st)
        worst = max(st) if ok else None  # type: ignore[type-var]
        rows.append(["uthinf", f"settles within {c['settle_within_s']:g} s",
                     f"E/N within 1.2× final from {tables.num(st[0], '.1f')} / "
                     f"{tables.num(st[1], '.1f')} s",
                     tables.MISSING if worst is None else ("yes" if worst <= c["settle_within_s"]
                                                           else "no")])
    return rows


def _claims_ukf(c: dict[str, Any], e: dict[str, Any]) -> list[list[str]]:
    if not c.get("east"):
        return []
    trend = e.get("east_trend_arcmin_per_100s")
    q = (e.get("rms_window_arcmin") or {}).get("east") or []
    if len(q) < 4 or not all(isinstance(v, int | float) for v in q):
        return []
    grows = q[-1] > 1.2 * q[1]  # diverging: the last quarter 20 % above the second
    return [["ukf", f"east: {c['east']}",
             f"E RMS by quarter {_windows(e)}′; trend over the second half "
             f"{tables.num(trend, '+.2f')}′/100 s", "yes" if grows else "no"]]


def claim_rows(summary: dict[str, Any]) -> list[list[str]]:
    """The paper's claims beside our numbers."""
    claims = (summary.get("paper") or {}).get("claims") or {}
    filters = summary.get("filters") or {}
    rows: list[list[str]] = []
    for name, fn in (("uthinf", _claims_uthinf), ("ukf", _claims_ukf)):
        e = filters.get(name)
        if name in claims and e and e.get("runs_scored"):
            rows += fn(claims[name], e)
    return rows


LIMIT_HEADER = ("quantity", "value")


def limit_rows(summary: dict[str, Any]) -> list[list[str]]:
    """The theoretical limits of :func:`slam.kinds.alignment.scoring.limits`."""
    lim = summary.get("limits") or {}
    az = lim.get("azimuth_limit_deg")
    return [
        ["accelerometer bias σ (constant ⊕ Markov)",
         f"{tables.num(lim.get('accel_bias_sigma_g'), '.2e')} g"],
        ["level limit ∇/g (East and North)", f"{tables.num(lim.get('tilt_limit_arcmin'), '.2f')}′"],
        ["gyro drift σ (constant ⊕ Markov)",
         f"{tables.num(lim.get('gyro_drift_sigma_deg_h'), '.1f')} °/h"],
        ["horizontal Earth rate Ω cos L",
         f"{tables.num(lim.get('earth_rate_horizontal_deg_h'), '.2f')} °/h"],
        ["azimuth limit ε_E / (Ω cos L)",
         f"{tables.num(az, '.1f')}°" if az is not None else
         f"none: drift is {tables.num(lim.get('drift_over_earth_rate'), '.1f')}× the Earth rate; "
         "azimuth is not observable"],
    ]


def _facts(summary: dict[str, Any]) -> str:
    mis = summary.get("initial_misalignment_deg") or []
    return (f"{summary.get('runs', '?')} runs of {tables.num(summary.get('duration_s'), 'g')} s;"
            f" IMU at {tables.num(summary.get('imu_rate_hz'), 'g')} Hz, filters at "
            f"{tables.num(summary.get('filter_rate_hz'), 'g')} Hz "
            f"(γ = {tables.num(summary.get('gamma'), 'g')}, on failure: "
            f"{summary.get('on_failure') or tables.MISSING} for uthinf/srchinf); wind "
            f"compliance {tables.num(summary.get('compliance_m_per_mps'), 'g')} m per m/s, "
            f"assumed velocity σ {tables.num(summary.get('velocity_sigma_mps'), 'g')} m/s; "
            "initial misalignment "
            f"{', '.join(tables.num(v, 'g') for v in mis)}° (E, N, Up); "
            "low-frequency (0.25 Hz) wind "
            f"amplitude {summary.get('low_frequency_wind_mps')} m/s. Errors: residual "
            "misalignment in arcmin, RMS over the runs at the last epoch. Settling: the epoch "
            "after which the Monte Carlo RMS stays within "
            f"{tables.num(summary.get('settle_factor'), 'g')}"
            "× its final value. 'E RMS by quarter': East error RMS over each quarter of the run; "
            "trend: slope of the East RMS over the second half. ANEES: 3-dof misalignment; level: "
            "East and North alone (2-dof); "
            "13-dof: the whole error state. H∞ fallbacks: updates whose existence condition "
            "failed (the Kalman update taken) / updates. ms/cycle: a filter's wall time per "
            "predict + update cycle; s/run: every estimator's wall time per run (the smoother's "
            "solve). The smoother's keys are 1 s apart; it runs on the "
            f"first {summary.get('reference_runs', '?')} runs.")


HOW_TO_READ = (
    "Every filter runs the same additive-quaternion-error model (exact discretisation of "
    "the paper's eq. 2-3 over each 100 ms interval) against the SINS velocity with a "
    "zero-velocity reference; the wind moves the launcher, and that motion is the only "
    "thing the reference does not know. The level (East, North) misalignment is "
    "observable and its floor is the accelerometer bias over g; the azimuth is not: "
    "the gyro drift (0.01°/s per axis, ≈ 36-51 °/h) is larger than the horizontal Earth "
    "rate, so gyrocompassing cannot find the heading, and every estimator's azimuth "
    "stays near its initial error. The filters' velocity error uses the rotation "
    "R(Q/|Q|) of the unnormalised quaternion: the paper's quadratic |Q|²R(Q) made the "
    "vertical channel measure |Q|², and that pseudo-measurement of the unit-norm "
    "constraint, linearised on the curved set of unit quaternions, shrank the azimuth σ "
    "from 30° to about 1° even on a calm launcher (tests/slam/kinds/alignment/"
    "test_consistency.py). What is left is the wind: the zero-velocity reference treats "
    "the launcher's motion as white noise although the accelerometers sense it; the "
    "likelihood of the velocities is flat in azimuth (a rotation about the vertical "
    "keeps the motion's size) but its linearisation adds |v_h|²/σ_v² ≈ 1.7 rad⁻² per "
    "update, so the azimuth σ still shrinks, as 1/√(17 t) rad over the first 10 s "
    "(measured to 10 %) and to about 1.5° at 200 s, while the error stays near its start "
    "(the EKF's and the UKF's move further during the levelling: with the paper's small α "
    "the UKF's points lie at ±0.0036σ, a linearisation like the EKF's, where the cubature "
    "filters' lie at ±3.6σ): the 3-dof ANEES is that azimuth "
    "term; see the level-axes ANEES. The smoother's azimuth error also stays near its "
    "start, with a smaller σ than that (its ANEES; not examined here). The decision ranks "
    "the settled epochs (from [scoring] settled_from_s, the paper's 50 s) by each run's "
    "mean squared level (East, North) error and, apart, azimuth error, paired over the "
    "runs; the smoother's RMSE is given beside the ranking, not ranked. "
    + tables.consistency_rule())


def _note(summary: dict[str, Any]) -> str:
    ref = (summary.get("reference") or {}).get(REFERENCE) or {}
    n = ref.get("no_covariance_runs")
    if not n:
        return ""
    return (f" The smoother's marginal covariances failed on {n} run(s) "
            f"({'; '.join(ref.get('no_covariance_reasons') or [])}): no smoother NEES there.")


def alignment_sections(summary: dict[str, Any]) -> list[Section]:
    """The decision, the paper's ordering, results, the γ sweep, the paper's claims, the
    limits, how to read."""
    out = [*decision_sections(summary)]
    order = ordering_section(summary, "[Wu-Wang 2014] §4: the UT-H∞ filter aligns better "
                             "than the UKF, whose East error diverges under the "
                             "low-frequency wind.")
    if order is not None:
        out.append(order)
    out.append(Section("Results", RESULT_HEADER, result_rows(summary),
                       _facts(summary) + _note(summary)))
    if sweep_rows(summary):
        out.append(Section("H∞ γ sweep", SWEEP_HEADER, sweep_rows(summary), sweep_text(summary)))
    claims = claim_rows(summary)
    if claims:
        paper = summary.get("paper") or {}
        out.append(Section("Paper vs ours", CLAIM_HEADER, claims,
                           f"{paper.get('source', '')}. 'holds' for the UKF claim: the East "
                           "error's RMS over the last quarter of the run is more than 1.2× "
                           "its RMS over the second quarter."))
    out.append(Section("Theoretical limits", LIMIT_HEADER, limit_rows(summary),
                       "From the world's sensor numbers (total σ of constant and Markov "
                       "parts); compare with the final errors above."))
    out.append(Section("How to read this", text=HOW_TO_READ))
    return out



def text_table(summary: dict[str, Any]) -> str:
    """The results as aligned plain text (for the terminal, <= 100 columns)."""
    picks = {"estimator": "estimator", "final E (′)": "E′", "final N (′)": "N′",
             "final az (′)": "az′", "settle E (s)": "E s", "settle N (s)": "N s",
             "E trend (′/100 s)": "E trend", "ANEES [95 % band]": "ANEES",
             "in band": "in band", "verdict": "verdict", "ANEES level (E, N)": "level",
             "diverged": "diverged"}
    at = [RESULT_HEADER.index(k) for k in picks]  # by name: robust to new columns
    rows = [[r[i].split(" [")[0] for i in at] for r in result_rows(summary)]
    head = list(picks.values())
    lim = summary.get("limits") or {}
    tail = (f"limits: level {tables.num(lim.get('tilt_limit_arcmin'), '.2f')}′ (∇/g); azimuth "
            + ("not observable (drift "
               f"{tables.num(lim.get('drift_over_earth_rate'), '.1f')}× Earth rate)"
               if not lim.get("azimuth_observable") else
               f"{tables.num(lim.get('azimuth_limit_deg'), '.1f')}°"))
    notes = ["E′ N′ az′: RMS misalignment over the runs at the end, arcmin; E s, N s: "
             "seconds until the RMS stays within 1.2× its final value; E trend: east RMS "
             "change per 100 s over the second half; level: the ANEES of the east and north "
             "misalignment alone.",
             tables.band_note(summary), *tables.failure_notes(summary)]
    parts = [tables.plain_table(head, rows), "", tail, *(tables.wrap(n) for n in notes if n)]
    sweep = sweep_rows(summary)
    if sweep:
        at = [0, 1, 3, 5, 6, 9, 10]
        parts += ["", "H∞ γ sweep (on_failure = kalman; ΔMSE: level, vs the γ = ∞ twin):",
                  tables.plain_table([SWEEP_HEADER[i].replace(" (′²)", "") for i in at],
                                     [[r[i] for i in at] for r in sweep])]
    return "\n".join([*parts, "", decision_text(summary)])


TUM_NOTE = (f"{tum.ATTITUDE_NOTE}, ENU, body forward-left-up; the filters' corrected "
            "attitude at every filter epoch, the smoother's at its keys")
TUM_COV = ("t, then the 3 x 3 misalignment covariance row-major (rad², navigation-frame "
           "rotation vector, East-North-Up: q̂ = Exp(φ) ⊗ q)")
_TRACK, _TIMES = tum.pose_track(lambda o: (np.zeros((len(o.truth), 3)), o.truth))
write_tum_files, tum_links = tum.report_files(_TRACK, TUM_NOTE, TUM_COV,
                                              "attitude (zero position)", _TIMES)
"""The TUM files and covariance sidecars of every tracked run (module docstring) and the
report's entries for them."""


REPORT = KindReport("SINS initial alignment campaign ([Wu-Wang 2014])", alignment_sections,
                    Deferred("slam.kinds.alignment.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The alignment kind's report."""
