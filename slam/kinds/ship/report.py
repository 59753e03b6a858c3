"""Tables and sections of a ``ship`` campaign report ([Ding 2017]), from the summary dict.

* Results - every filter of the paper's comparison (and the baselines) and the smoother:
  RMS roll/pitch/yaw error, time to within 10′, yaw error at the end, ANEES, timing;
* Paper vs ours - each of the paper's claims next to our number and whether it holds;
* Effects - the same data through (a) UKF with the additive mean, (b) UKF with the
  eigenvector mean, (c) HoMM-UKF, (d) SRCKF and the MEKF on the manifold, (e) UKF on the
  manifold, with paired per-run comparisons;
* How to read this.

Figures are in :mod:`slam.kinds.ship.figures`; :data:`REPORT` is the kind's
:class:`~slam.render.document.KindReport`.
"""

from __future__ import annotations

from typing import Any

from slam.kind import Deferred
from slam.render import tables
from slam.render.document import KindReport, Section
from slam.results import REFERENCE

RULES = {"ekf": "linearised (MEKF)", "ukf": "unscented α=1 κ=0", "cdkf": "central diff. h=√3",
         "hommukf": "HoMM (s=0, k=3)", "srckf": "cubature, sqrt", "ckf": "cubature",
         "srukf": "unscented, sqrt", "srcdkf": "central diff., sqrt", "svdckf": "cubature, SVD"}
MEANS = {"paper": "eigenvector", "additive": "additive", "chart": "chart (iterative)",
         "manifold": "chart (iterative)"}
MEASUREMENTS = {"paper": "Z = G q", "additive": "Z = G q", "chart": "Z = G q",
                "manifold": "B = C(q)ᵀR"}
EFFECT_STEPS = (("(a)", "ukf:additive"), ("(b)", "ukf"), ("(c)", "hommukf"), ("(d)", "srckf"),
                ("(d)", "ekf"), ("(e)", "ukf:manifold"))


def _axes(d: Any, fmt: str = ".2f") -> list[str]:
    d = d if isinstance(d, dict) else {}
    return [tables.num(d.get(a), fmt) for a in ("roll", "pitch", "yaw")]


def _converge(e: dict[str, Any], key: str = "converge_roll_pitch_s") -> str:
    c = e.get(key) or {}
    cell = f"{tables.num(c.get('median'), '.0f')} [{tables.num(c.get('max'), '.0f')}]"
    never = c.get("never")
    return cell + (f" ({never} never)" if never else "")


def _final_yaw(e: dict[str, Any]) -> str:
    y = (e.get("final_abs_arcmin") or {}).get("yaw") or {}
    return f"{tables.num(y.get('mean'), '.2f')} ({tables.num(y.get('p95'), '.2f')})"


def _time(name: str, e: dict[str, Any]) -> str:
    if name == REFERENCE:
        return f"{tables.num(e.get('time_s'), '.2f')} s/run"
    return tables.num(e.get("time_per_cycle_s"), ".2f", 1e3)


def _treatment(name: str, e: dict[str, Any]) -> str:
    t = e.get("treatment")
    if name == REFERENCE:
        return "batch smoother"
    return f"{MEANS.get(t, t)} mean, {MEASUREMENTS.get(t, t)}"


RESULT_HEADER = ("estimator", "treatment", "RMS roll (′)", "RMS pitch (′)", "RMS yaw (′)",
                 "RMS yaw ss (′)", "roll/pitch < 10′ from (s) median [max]",
                 "yaw < 10′ from (s)", "|yaw| at end (′) mean (p95)", "ANEES [95 % band]",
                 "epochs in band", "verdict", "ANEES att", "NIS/dof ss", "ms/cycle",
                 "diverged")


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter and the smoother (columns :data:`RESULT_HEADER`)."""
    return [[name, _treatment(name, e), *_axes(e.get("att_rms_arcmin")),
             tables.num((e.get("att_rms_steady_arcmin") or {}).get("yaw"), ".2f"), _converge(e),
             _converge(e, "converge_yaw_s"), _final_yaw(e), tables.anees_cell(e),
             tables.num(e.get("anees_inside_95"), ".0%"), _verdict_word(e),
             tables.anees_cell(e, "anees_att", "anees_att_bounds_95"),
             tables.num(e.get("nis_mean_steady"), ".2f"), _time(name, e), tables.diverged_cell(e)]
            for name, e in tables.estimator_entries(summary)]


EFFECT_HEADER = ("step", "estimator", "points", "quaternion mean", "measurement",
                 "RMS roll (′)", "RMS pitch (′)", "RMS yaw (′)", "RMS yaw ss (′)",
                 "|yaw| at end (′)", "ANEES [95 % band]", "in band", "diverged")


def _entry(summary: dict[str, Any], name: str) -> dict[str, Any] | None:
    for group in ("filters", "variants"):
        e = (summary.get(group) or {}).get(name)
        if e is not None:
            return e
    return None


def effect_rows(summary: dict[str, Any]) -> list[list[str]]:
    """The effects table: the lettered steps present, then any other variants."""
    steps = [(s, n) for s, n in EFFECT_STEPS if _entry(summary, n) is not None]
    listed = {n for _, n in steps}
    steps += [("", n) for n in (summary.get("variants") or {}) if n not in listed]
    rows = []
    for step, name in steps:
        e = _entry(summary, name) or {}
        t = e.get("treatment")
        rows.append([step, name, RULES.get(name.partition(":")[0], "?"), MEANS.get(t, "?"),
                     MEASUREMENTS.get(t, "?"), *_axes(e.get("att_rms_arcmin")),
                     tables.num((e.get("att_rms_steady_arcmin") or {}).get("yaw"), ".2f"),
                     _final_yaw(e), tables.anees_cell(e),
                     tables.num(e.get("anees_inside_95"), ".0%"),
                     tables.diverged_cell(e)])
    return rows


COMPARISON_HEADER = ("a", "b", "what differs", "mean ΔMSE a−b (′²)", "± s.e.", "a better")


def comparison_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Paired per-run differences of the steady-state attitude MSE."""
    return [[c["a"], c["b"], c["what"], tables.num(c.get("mean"), ".3g"),
             tables.num(c.get("se"), ".3g"),
             f"{c.get('a_better_runs', '?')}/{c.get('runs', '?')}"]
            for c in summary.get("comparisons") or [] if c.get("runs")]


CLAIM_HEADER = ("filter", "paper", "ours", "holds")


def _bound_row(name: str, e: dict[str, Any], bound: float, axes: tuple[str, ...],
               window: str) -> list[str]:
    worst = e.get("att_max_abs_steady_p95_arcmin") or {}
    vals = [worst.get(a) for a in axes]
    ours = max(vals) if all(isinstance(v, int | float) for v in vals) else None
    holds = tables.MISSING if ours is None else ("yes" if ours <= bound else "no")
    return [name, f"{', '.join(axes)} within {bound:g}′",
            f"{tables.num(ours, '.2f')}′ (95 % of runs stay below, {window})", holds]


def claim_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Each claim of the paper beside our number (see :data:`HOW_TO_READ`)."""
    claims = (summary.get("paper") or {}).get("claims") or {}
    w = summary.get("steady_state_window_s") or [0, 0]
    window = f"{tables.num(w[0], 'g')}-{tables.num(w[1], 'g')} s"
    rows = []
    for name, c in claims.items():
        e = (summary.get("filters") or {}).get(name)
        if e is None or not e.get("runs_scored"):
            rows.append([name, "(not run or diverged on every run)", tables.MISSING,
                         tables.MISSING])
            continue
        if isinstance(c.get("roll_pitch_within_arcmin"), int | float):
            rows.append(_bound_row(name, e, c["roll_pitch_within_arcmin"], ("roll", "pitch"),
                                   window))
        if isinstance(c.get("yaw_within_arcmin"), int | float):
            rows.append(_bound_row(name, e, c["yaw_within_arcmin"], ("yaw",), window))
        if c.get("yaw"):
            rows.append([name, f"yaw {c['yaw']}",
                         f"yaw < 10′ from {_converge(e, 'converge_yaw_s')} s; "
                         f"|yaw| at end {_final_yaw(e)}′", "see text"])
    return rows


def _facts(summary: dict[str, Any]) -> str:
    w = summary.get("steady_state_window_s") or [None, None]
    return (f"{summary.get('runs', '?')} runs of {tables.num(summary.get('duration_s'), 'g')} s; "
            f"gyro at {tables.num(summary.get('gyro_rate_hz'), 'g')} Hz, vector updates at "
            f"{tables.num(summary.get('update_rate_hz'), 'g')} Hz. Errors in arcmin (′) of the "
            "Z-Y-X Euler angles, RMS over the runs and the whole run (ss: steady state "
            f"{tables.num(w[0], 'g')}-{tables.num(w[1], 'g')} s). "
            "Times to converge: the first epoch after "
            "which the error stays below 10′ to the end (median [max] over runs). ANEES: "
            "6-dof (attitude and drift) against the 95 % band of one epoch; 'ANEES att' is "
            "the 3-dof attitude part. Cycle times are wall-clock inside the campaign's "
            "workers: one cycle is the prediction through one interval's gyro samples and "
            "one update.")


HOW_TO_READ = (
    "The paper compares UKF, CDKF and HoMM-UKF on one model - the pseudo-observation "
    "Z = G q with the noise-separation covariance and the eigenvector quaternion mean - "
    "and gives its results only as figures and sentences (roll and pitch within 10′; UKF "
    "yaw within 40′ and slow, CDKF within 60′; HoMM-UKF more accurate). Which vectors it "
    "observes, their noise and rate, the wave motion and the initial covariance are not "
    "stated; the world file says what we chose. A bound 'holds' when 95 % of the runs "
    "keep the error below it over the steady-state window. The HoMM rule matches the "
    "Gaussian third and fourth moments (skewness 0, kurtosis 3): the state's prior is "
    "Gaussian, and for it the paper's eq. (20)-(22) reduce to Julier's unscented set with "
    "κ = 3 − n; the paper's φ1, φ2 computed from its own points (eq. after 20) would "
    "return those values. Every filter uses the same process model (the exact "
    "propagation through the gyro samples with the Earth rate, tangent-space noise); "
    "the effects table changes one thing at a time on the same data: the quaternion mean "
    "((a) vs (b)), the point rule ((b) vs (c)) and the measurement model with the mean "
    "((b) vs (e)); (d) are the common baselines. ΔMSE is the per-run difference of the "
    "steady-state attitude mean squared error (roll² + pitch² + yaw²), a minus b, with "
    "its standard error over the runs.")


def _sentence(c: dict[str, Any]) -> str:
    """``"a is more accurate than b (...)"`` from a paired comparison, at 2 s.e."""
    m, se = c["mean"], c["se"]
    if m + 2.0 * se < 0.0:
        what = "is more accurate than"
    elif m - 2.0 * se > 0.0:
        what = "is less accurate than"
    else:
        what = "is not distinguishable (within 2 s.e.) from"
    return (f"{c['a']} {what} {c['b']} ({c['what']}: ΔMSE {m:.3g} ± {se:.3g} ′², "
            f"{c['a']} better in {c['a_better_runs']}/{c['runs']} runs).")


PAPER_ORDER = {("hommukf", "ukf"), ("hommukf", "cdkf")}


def _verdict(summary: dict[str, Any], paper: bool = True) -> str:
    """One plain sentence per paired comparison: the paper's ordering (``paper``) or the
    effects (the others), from the numbers."""
    return " ".join(_sentence(c) for c in summary.get("comparisons") or []
                    if c.get("runs") and ((c["a"], c["b"]) in PAPER_ORDER) == paper)


def ship_sections(summary: dict[str, Any]) -> list[Section]:
    """Results, the paper's claims, the effects, the paired comparisons, how to read."""
    out = [Section("Results", RESULT_HEADER, result_rows(summary), _facts(summary))]
    claims = claim_rows(summary)
    if claims:
        paper = summary.get("paper") or {}
        source = f"{paper['source']}." if paper.get("source") else ""
        text = " ".join(t for t in (source, paper.get("note") or "", _verdict(summary)) if t)
        out.append(Section("Paper vs ours", CLAIM_HEADER, claims, text))
    effects = effect_rows(summary)
    if effects:
        out.append(Section("Effects: mean, point rule, measurement model", EFFECT_HEADER,
                           effects, "Same runs, same data, one change per step. "
                           + _verdict(summary, paper=False)))
    comp = comparison_rows(summary)
    if comp:
        out.append(Section("Paired comparisons", COMPARISON_HEADER, comp,
                           "Negative ΔMSE: a is more accurate."))
    out.append(Section("How to read this", text=HOW_TO_READ))
    return out



def _verdict_word(entry: dict[str, Any]) -> str:
    return tables.verdict(entry, inside="anees_inside_95", above="anees_above_95") or tables.MISSING


def text_table(summary: dict[str, Any]) -> str:
    """The results and the effects as aligned plain text that fits the terminal (the
    ANEES band in a note), the failure reasons and the verdicts."""
    res = [[*r[:1], *r[2:6], r[9].split(" [")[0], *r[10:12], *r[14:16]]
           for r in result_rows(summary)]
    head = ["estimator", "roll′", "pitch′", "yaw′", "yaw ss′", "ANEES", "in band", "verdict",
            "ms/cycle", "diverged"]
    eff = [[r[0], r[1], r[3], r[4], r[7], r[8], r[10].split(" [")[0]]
           for r in effect_rows(summary)]
    parts = [tables.plain_table(head, res)]
    if eff:
        parts += ["", tables.plain_table(["step", "estimator", "mean", "measurement", "yaw′",
                                          "yaw ss′", "ANEES"], eff)]
    notes = ["RMS errors in arcmin; yaw ss′: from the steady-state start (convergence times "
             "and final yaw in the report).", tables.band_note(summary),
             *tables.failure_notes(summary),
             _verdict(summary), _verdict(summary, paper=False)]
    return "\n".join([*parts, "", *(tables.wrap(n) for n in notes if n)])


REPORT = KindReport("ship SINS attitude campaign ([Ding 2017])", ship_sections,
                    Deferred("slam.kinds.ship.figures:figures"), text_table)
"""The ship kind's report."""
