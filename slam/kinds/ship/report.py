"""Tables and sections of a ``ship`` campaign report ([Ding 2017]), from the summary dict.

* Decision - the headline, the paired rankings (steady-state and whole-run attitude MSE)
  and every filter's settings (:mod:`slam.render.decision`);
* The paper's ordering - each ranked filter's rank and paired ΔMSE against the best on
  both metrics, its ANEES and in-band share, the paper's rank beside it, and the
  paper's pairs tested one by one;
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
from slam.render import tables, tum
from slam.render.decision import decision_sections, decision_text, delta_text
from slam.render.document import KindReport, Section
from slam.results import REFERENCE

RULES = {"ekf": "linearised (MEKF)", "ukf": "unscented", "cdkf": "central difference",
         "hommukf": "HoMM", "srckf": "cubature, sqrt", "ckf": "cubature",
         "srukf": "unscented, sqrt", "srcdkf": "central diff., sqrt", "svdckf": "cubature, SVD"}
"""The point rule of each filter (its constants are the entry's ``settings_text``)."""
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


def _cycle_ms(name: str, e: dict[str, Any]) -> str:
    """A filter's wall time per predict + update cycle (ms); the smoother has none."""
    return tables.MISSING if name == REFERENCE else tables.num(e.get("time_per_cycle_s"),
                                                              ".2f", 1e3)


def _run_s(name: str, e: dict[str, Any]) -> str:
    """Wall time per run (s): the filter's cycles, or the smoother's solve."""
    return tables.num(e.get("time_s" if name == REFERENCE else "time_per_run_s"), ".2f")


def _treatment(name: str, e: dict[str, Any]) -> str:
    t = e.get("treatment")
    if name == REFERENCE:
        return "batch smoother"
    return f"{MEANS.get(t, t)} mean, {MEASUREMENTS.get(t, t)}"


RESULT_HEADER = ("estimator", "treatment", "RMS roll (′)", "RMS pitch (′)", "RMS yaw (′)",
                 "RMS yaw ss (′)", "roll/pitch < 10′ from (s) median [max]",
                 "yaw < 10′ from (s)", "|yaw| at end (′) mean (p95)", "ANEES [95 % band]",
                 "epochs in band", "verdict", "ANEES att", "NIS/dof ss", "ms/cycle",
                 "s/run", "diverged")


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter and the smoother (columns :data:`RESULT_HEADER`)."""
    return [[name, _treatment(name, e), *_axes(e.get("att_rms_arcmin")),
             tables.num((e.get("att_rms_steady_arcmin") or {}).get("yaw"), ".2f"), _converge(e),
             _converge(e, "converge_yaw_s"), _final_yaw(e), tables.anees_cell(e),
             tables.percent(e.get("anees_inside_95")), _verdict_word(e),
             tables.anees_cell(e, "anees_att", "anees_att_bounds_95"),
             tables.num(e.get("nis_mean_steady"), ".2f"), _cycle_ms(name, e), _run_s(name, e),
             tables.diverged_cell(e)]
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
        rows.append([step, name, _rule(name, e), MEANS.get(t, "?"),
                     MEASUREMENTS.get(t, "?"), *_axes(e.get("att_rms_arcmin")),
                     tables.num((e.get("att_rms_steady_arcmin") or {}).get("yaw"), ".2f"),
                     _final_yaw(e), tables.anees_cell(e),
                     tables.percent(e.get("anees_inside_95")),
                     tables.diverged_cell(e)])
    return rows


def _rule(name: str, e: dict[str, Any]) -> str:
    """The point rule and its stated constants."""
    rule = RULES.get(name.partition(":")[0], "?")
    return f"{rule} ({e['settings_text']})" if e.get("settings_text") else rule


COMPARISON_HEADER = ("a", "b", "what differs", "mean ΔMSE a−b (′²)", "± s.e.", "a better")


def comparison_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Paired per-run differences of the steady-state attitude MSE."""
    return [[c["a"], c["b"], c["what"], tables.num(c.get("mean"), ".3g"),
             tables.num(c.get("se"), ".3g"),
             f"{c.get('a_better_runs', '?')}/{c.get('runs', '?')}"]
            for c in summary.get("comparisons") or [] if c.get("runs")]


ORDER_HEADER = ("filter", "paper's rank", "rank ss", "ΔMSE ss vs best (′²)", "rank all",
                "ΔMSE all vs best (′²)", "ANEES [95 % band]", "epochs in band", "verdict")
METRIC_KEYS = ("attitude_steady", "attitude")


def _rank_cells(summary: dict[str, Any], key: str, name: str) -> list[str]:
    row = (((summary.get("ranking") or {}).get(key) or {}).get("rows") or {}).get(name)
    if row is None:
        return [tables.MISSING, tables.MISSING]
    if row["verdict"] == "best":
        return [str(row["rank"]), "best"]
    return [str(row["rank"]), f"{delta_text(row)} ({row['verdict']})"]


def ordering_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Every ranked filter (best steady-state first): the paper's rank, ours on both
    metrics with the paired ΔMSE ± s.e. against the best, the ANEES and its in-band
    share (columns :data:`ORDER_HEADER`)."""
    order = (summary.get("paper_ordering") or {}).get("order") or []
    block = (summary.get("ranking") or {}).get(METRIC_KEYS[0]) or {}
    rows = []
    for name in block.get("order") or []:
        e = (summary.get("filters") or {}).get(name) or {}
        paper = str(order.index(name) + 1) if name in order else "-"
        rows.append([name, paper, *_rank_cells(summary, METRIC_KEYS[0], name),
                     *_rank_cells(summary, METRIC_KEYS[1], name), tables.anees_cell(e),
                     tables.percent(e.get("anees_inside_95")), _verdict_word(e)])
    return rows


def ordering_text(summary: dict[str, Any]) -> str:
    """The paper's pairs tested one by one, and whether its ordering is reproduced."""
    po = summary.get("paper_ordering") or {}
    if not po.get("order"):
        return ""
    labels = {k: b.get("label", k) for k, b in (summary.get("ranking") or {}).items()}
    parts = [f"The paper's ordering (best first): {' > '.join(po['order'])}."]
    for key, verdict in (po.get("reproduced") or {}).items():
        pairs = [p for p in po["pairs"] if p["metric"] == key]
        cells = [f"{p['a']} − {p['b']} {tables.num(p.get('mean'), '+.3g')} ± "
                 f"{tables.num(p.get('se'), '.2g')} ′² ({p['holds']}"
                 + (f", z {p['z']:.1f}" if p.get("z") is not None else "") + ")"
                 for p in pairs]
        word = {"yes": "reproduced", "no": "not reproduced (a pair is reversed)",
                "partly": "partly reproduced",
                "unresolved": "not resolved (no pair distinguishable)"}[verdict]
        parts.append(f"{labels.get(key, key)}: {'; '.join(cells)} - {word}.")
    parts.append("A pair holds when the first filter's per-run MSE is lower by more than 2 "
                 "standard errors of the paired difference.")
    return " ".join(parts)


def coincidence_text(summary: dict[str, Any]) -> str:
    """The largest gap between the paper-model filters' curves in convergence.png."""
    c = summary.get("coincidence") or {}
    pairs = c.get("pairs") or []
    if not pairs:
        return ""
    cells = ", ".join(f"{p['a']}/{p['b']} {p['max_arcmin']:.3g}′" for p in pairs)
    return ("convergence.png: the median |error| curves of the paper-model filters differ by "
            f"at most {c['max_arcmin']:.3g}′ over every epoch and axis ({cells}); curves "
            "closer than a line width coincide in the figure.")


def moments_text(summary: dict[str, Any]) -> str:
    """What the predicted-moments HoMM-UKF drew with, per filter that has it."""
    out = []
    for name, e in (summary.get("filters") or {}).items():
        m = e.get("homm_moments")
        if not m:
            continue
        k, k30, s = m["kurtosis"], m["kurtosis_first_30s"], m["skewness"]
        out.append(
            f"{name} drew its points with the paper's φ₁, φ₂ of the predicted points (eq. 20 "
            f"and after): kurtosis N·φ₂ median {k['median']:.3g} (5-95 % {k['p5']:.3g}-"
            f"{k['p95']:.3g}, range {k['min']:.3g}-{k['max']:.3g}; first 30 s median "
            f"{k30['median']:.3g}, {k30['p5']:.3g}-{k30['p95']:.3g}) where a Gaussian has 3, "
            f"skewness √N·φ₁ {s['min']:.2g} to {s['max']:.2g}; {m['fallbacks']} of "
            f"{m['predictions']} estimates refused (kurtosis ≤ skewness²: the stated moments "
            "used instead), over its "
            f"{m['runs']} runs. The process model is a rotation of the attitude error (up to "
            "the drift), so the predicted points stay nearly symmetric (the skewness above) "
            "and the kurtosis moves because a linear map mixes the axes of a 2n+1 point set "
            "(it has no mixed fourth moments) and the paper's normalisation by the Cholesky "
            "factor's fourth powers does not undo it.")
    return " ".join(out)


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
    "keep the error below it over the steady-state window. The HoMM rule places its points "
    "by eq. (20)-(22) from a skewness and a kurtosis: with [filters.homm] moments = "
    "\"predicted\" (the paper's mechanism) they are the paper's φ1, φ2 of the predicted "
    "points, recomputed at every prediction (eq. after 20); the prior's draw uses the "
    "stated Gaussian values (skewness 0, kurtosis 3), for which eq. (20)-(22) are Julier's "
    "unscented set with κ = 3 − n - the UKF's stated set here, so HoMM-UKF vs UKF is the "
    "paper's mechanism switched on and off. The predicted points are not Gaussian-moment "
    "points: the paper's estimate from the Gaussian set after a rotation is kurtosis 2.02 "
    "(skewness 0), after a quadratic map skewness 1.35 and kurtosis 3.82 "
    "(tests/estimators/test_homm_predicted.py). "
    "Every filter uses the same process model (the exact "
    "propagation through the gyro samples with the Earth rate, tangent-space noise); "
    "the effects table changes one thing at a time on the same data: the quaternion mean "
    "((a) vs (b)), the point rule ((b) vs (c)) and the measurement model with the mean "
    "((b) vs (e)); (d) are the common baselines. ΔMSE is the per-run difference of the "
    "steady-state attitude mean squared error (roll² + pitch² + yaw²), a minus b, with "
    "its standard error over the runs.")


def _sentence(c: dict[str, Any]) -> str:
    """``"a is more accurate than b (...)"`` from a paired comparison, at 2 s.e."""
    m, se = c["mean"], c.get("se")
    if se is None:
        return f"{c['a']} vs {c['b']}: no standard error ({c.get('se_reason', '')})."
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
    """The decision, the paper's ordering, results, the paper's claims, the effects, the
    paired comparisons, how to read."""
    out = list(decision_sections(summary))
    order = ordering_rows(summary)
    if order:
        out.append(Section("The paper's ordering: ranks, paired ΔMSE and consistency",
                           ORDER_HEADER, order, ordering_text(summary)))
    facts = " ".join(t for t in (_facts(summary), moments_text(summary),
                                 coincidence_text(summary)) if t)
    out.append(Section("Results", RESULT_HEADER, result_rows(summary), facts))
    claims = claim_rows(summary)
    if claims:
        paper = summary.get("paper") or {}
        source = f"{paper['source']}." if paper.get("source") else ""
        text = " ".join(t for t in (source, paper.get("note") or "") if t)
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
    res = [[*r[:1], *r[2:6], r[9].split(" [")[0], *r[10:12], *r[14:17]]
           for r in result_rows(summary)]
    head = ["estimator", "roll′", "pitch′", "yaw′", "yaw ss′", "ANEES", "in band", "verdict",
            tables.EPOCH_TIME, tables.RUN_TIME, tables.TERMINAL_HEADERS["diverged runs"]]
    eff = [[r[0], r[1], r[3], r[4], r[7], r[8], r[10].split(" [")[0]]
           for r in effect_rows(summary)]
    parts = [tables.plain_table(head, res)]
    if eff:
        parts += ["", tables.plain_table(["step", "estimator", "mean", "measurement", "yaw′",
                                          "yaw ss′", "ANEES"], eff)]
    notes = ["RMS errors in arcmin; yaw ss′: from the steady-state start (convergence times "
             "and final yaw in the report).", tables.band_note(summary),
             *tables.failure_notes(summary), _verdict(summary, paper=False),
             moments_text(summary), ordering_text(summary)]
    return "\n".join([*parts, "", *(tables.wrap(n) for n in notes if n), "",
                      decision_text(summary)])


def _quats(o, name: str):
    return o.truth[:, :4] if name == "truth" else o.tracks[name].means[:, :4]


def _covs(o, name: str):
    return None if name == "truth" else o.tracks[name].covs


write_tum_files, tum_links = tum.attitude_files(_quats, _covs,
                                                "poses at the vector-measurement epochs")
"""TUM files (zero position) and attitude covariance sidecars of the tracked runs, and the
report's entries for them (:func:`slam.render.tum.attitude_files`)."""


REPORT = KindReport("ship SINS attitude campaign ([Ding 2017])", ship_sections,
                    Deferred("slam.kinds.ship.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The ship kind's report."""
