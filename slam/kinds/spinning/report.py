"""Tables and sections of a ``spinning`` campaign's report (from ``summary.json`` alone).

* Decision (first): the headline, the paired rankings by pitch, yaw and blind-area roll
  (:mod:`slam.render.decision`) and the filters' settings.
* Results: pitch / yaw mean absolute error and RMSE, the implied roll's RMSE outside and
  inside the geomagnetic blind area, consistency, H∞ existence failures, timing.
* Paper vs ours: [Spin SR-CH∞KF] publishes no error numbers, only Table 2's flight and
  its figures' rankings; both are set next to ours.
* The H∞ existence check per γ, and the noise-mismatch sweeps (one table per mismatch -
  gyro and magnetometer together, gyro only, magnetometer only - and noise shape).
* How to read this: what differs from the paper and why.

Files: ``truth.tum`` and ``<estimator>.tum`` with ``<estimator>.cov.txt`` of every tracked
run (run 0; every run with ``slam run --tum all``: :mod:`slam.render.tum`): attitude only
(zero position), ``q_nb`` of ``C_nb = R_y(yaw) R_z(pitch) R_x(roll)``
(North-Up-East) from each estimator's pitch and yaw and the roll they imply (eq. 7-8) at
every epoch; the sidecar holds the estimator's 2 × 2 pitch/yaw covariance.

The figures are :mod:`slam.kinds.spinning.figures`; :data:`REPORT` is the kind's
:class:`~slam.render.document.KindReport`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from nav.quaternion import dcm_to_q
from slam.kind import Deferred
from slam.render import tables, tum
from slam.render.decision import decision_sections, decision_text
from slam.render.document import KindReport, Section
from slam.results import REFERENCE, Array, RunOutcome


def _fallback_cell(name: str, e: dict[str, Any]) -> str:
    if "hinf_fallbacks" not in e:
        return tables.MISSING
    return f"{e['hinf_fallbacks']}/{e['hinf_updates']}"


def _time_cell(name: str, e: dict[str, Any]) -> str:
    if name == REFERENCE:  # a batch solve: its cost is per run (smoother_cost)
        return tables.MISSING
    return tables.num(e.get("time_per_cycle_s"), ".3f", 1e3)


def smoother_cost(s: dict[str, Any]) -> str:
    """The GTSAM smoother's cost in its own unit: seconds per run (solve, marginals)."""
    r = (s.get("reference") or {}).get(REFERENCE)
    if not r:
        return ""
    return (f"The GTSAM smoother costs {tables.num(r.get('time_s'), '.2f')} s per run to "
            f"solve (EKF start + Levenberg-Marquardt) and "
            f"{tables.num(r.get('marginals_time_s'), '.2f')} s for its marginals.")


RESULTS = tables.Table((
    tables.Column("estimator", lambda name, e: "gtsam smoother" if name == REFERENCE else name),
    tables.Column("pitch mean abs (°)", tables.value("pitch_mean_abs_deg", ".4f")),
    tables.Column("pitch RMSE (°)", tables.value("pitch_rmse_deg", ".4f")),
    tables.Column("yaw mean abs (°)", tables.value("yaw_mean_abs_deg", ".3f")),
    tables.Column("yaw RMSE (°)", tables.value("yaw_rmse_deg", ".3f")),
    tables.Column("roll RMSE outside (°)", tables.value("roll_rmse_outside_deg", ".3f")),
    tables.Column("roll RMSE blind (°)", tables.value("roll_rmse_blind_deg", ".2f")),
    *tables.consistency_columns(), tables.Column("NIS", tables.value("nis_mean", ".2f")),
    tables.Column("H∞ fallbacks", _fallback_cell),
    tables.Column("time/cycle (ms)", _time_cell), tables.DIVERGED))
"""The results table: a row per filter and the smoother."""


def result_rows(summary: dict[str, Any]) -> list[list[str]]:
    """:data:`RESULTS`' rows, then the roll floor (eq. 7-8 with the true pitch and yaw)."""
    rows = RESULTS.rows(summary)
    floor = summary.get("roll_floor") or {}
    if floor:
        row = [tables.MISSING] * len(RESULTS.columns)
        row[0] = "roll floor (true pitch, yaw)"
        row[5] = tables.num(floor.get("roll_rmse_outside_deg"), ".3f")
        row[6] = tables.num(floor.get("roll_rmse_blind_deg"), ".2f")
        rows.append(row)
    return rows


def _results_text(s: dict[str, Any]) -> str:
    tn = s.get("truth_noise") or {}
    b = s.get("blind_area") or {}
    return (f"{s.get('runs', '?')} runs, every epoch of the flight (Δt = "
            f"{tables.num(s.get('sample_interval_s'), 'g')} s). True noise: magnetometer "
            f"{tables.num(tn.get('magnetometer_factor'), 'g')}×, "
            f"gyro {tables.num(tn.get('gyro_factor'), 'g')}× "
            f"what the filters assume, {tn.get('distribution', '?')}. Roll is eq. 7-8 on the "
            "measured radial field with each estimator's pitch and yaw, wrapped to ±180°; "
            f"'blind' is the geomagnetic blind area (body axis within "
            f"{tables.num(b.get('threshold_deg'), 'g')}° of the field line, "
            f"{tables.num(b.get('from_s'), '.1f')}-{tables.num(b.get('to_s'), '.1f')} s; "
            "a detector on the measured radial field agrees on "
            f"{tables.num(b.get('detector_agreement'), '.1%')} of the epochs: misses "
            f"{tables.num(b.get('detector_missed'), '.1%')} of the blind ones, flags "
            f"{tables.num(b.get('detector_false'), '.1%')} of the others). The roll floor row "
            "uses the true pitch and yaw: what the magnetometer's noise alone leaves. "
            "ANEES is the run-averaged 2-dof pitch/yaw NEES over 2 against the 95 % band of "
            f"one epoch; 'H∞ fallbacks' are updates whose existence condition failed (γ = "
            f"{tables.num(s.get('gamma_rad'), 'g')} rad). Cycle times are wall-clock inside the "
            "campaign's workers. " + smoother_cost(s) + " " + tables.consistency_rule())


CLAIMS = (("best_pitch", "pitch", "best"), ("worst_pitch", "pitch", "worst"),
          ("best_yaw", "yaw", "best"), ("worst_yaw", "yaw", "worst"),
          ("best_roll_blind", "roll_blind", "best"))
"""The paper's ordering claims ([paper] key, ranked metric, best or worst)."""


def claim_verdict(block: dict[str, Any], name: str, side: str) -> str:
    """Whether the paired ranking ``block`` bears out that ``name`` is the ``side``
    ("best" or "worst") filter: "reproduced", "contradicted" or "not decided" with the
    evidence (significant = ΔMSE > 2 s.e. against the best)."""
    rows, order = block.get("rows") or {}, block.get("order") or []
    if name not in rows:
        return f"not tested ({name} not ranked)"
    r, n = rows[name], len(order)
    where = f"{name} ranked {r['rank']} of {n}"
    sig = ("significant", "separated", "worse")
    if side == "best":
        if r["rank"] == 1:
            nxt = rows[order[1]] if n > 1 else None
            if nxt is not None and nxt["verdict"] in sig:
                return f"reproduced ({where}; the next, {order[1]}, {_z(nxt)} worse)"
            return f"not decided ({where}, but within 2 s.e. of {order[1]})" if nxt else where
        if r["verdict"] in sig:
            return f"contradicted ({where}: {_z(r)} worse than {order[0]})"
        return f"not decided ({where}, within 2 s.e. of {order[0]})"
    if r["rank"] == n and r["verdict"] in sig:
        return f"reproduced ({where}: {_z(r)} worse than the best)"
    last = rows[order[-1]]
    if r["rank"] == 1 and last["verdict"] in sig:
        return f"contradicted ({name} is the best; {order[-1]} {_z(last)} worse)"
    if r["rank"] == n:
        return f"not decided ({where}, within 2 s.e. of {order[0]})"
    return f"not reproduced ({where}; last: {order[-1]})"


def _z(row: dict[str, Any]) -> str:
    z = row.get("z")
    return "in every run" if z is None else f"{z:.1f} s.e."


def claim_rows(s: dict[str, Any]) -> list[list[str]]:
    """``[claim, paper, ours]`` for the paper's ordering claims (:data:`CLAIMS`), judged on
    the paired ranking among the paper's own five filters (``paper_ranking``)."""
    p, ranking = s.get("paper") or {}, s.get("paper_ranking") or {}
    rows = []
    for key, metric, side in CLAIMS:
        if key not in p or metric not in ranking:
            continue
        name = str(p[key]).split()[0]
        label = ranking[metric]["label"]
        rows.append([f"{side} {label}", str(p[key]), claim_verdict(ranking[metric], name, side)])
    return rows


def paper_rows(s: dict[str, Any]) -> list[list[str]]:
    """The paper's Table 2 and its figures' statements next to ours."""
    f = s.get("flight") or {}
    p = s.get("paper") or {}
    b = s.get("blind_area") or {}
    return [
        ["flight time (s)", tables.num(f.get("target_flight_time_s"), "g"),
         tables.num(f.get("flight_time_s"), ".2f")],
        ["range (m)", tables.num(f.get("target_range_m"), ".1f"),
         tables.num(f.get("range_m"), ".1f")],
        ["apex (m)", tables.num(f.get("target_apex_m"), "g"),
         tables.num(f.get("apex_m"), ".1f")],
        *claim_rows(s),
        ["blind area", p.get("blind_area", tables.MISSING),
         f"{tables.num(b.get('from_s'), '.1f')}-{tables.num(b.get('to_s'), '.1f')} s (axis within "
         f"{tables.num(b.get('threshold_deg'), 'g')}° of the field line; closest "
         f"{tables.num(b.get('closest_angle_deg'), '.2f')}° at "
         f"{tables.num(b.get('closest_at_s'), '.1f')} s)"],
    ]


def _gamma_text(g: Any) -> str:
    return "∞" if g is None or (isinstance(g, float) and math.isinf(g)) else format(g, "g")


def _sweep_groups(sweep: dict[str, Any]) -> list[tuple[str, str]]:
    """The sweep's (scale, distribution) pairs in table order."""
    return [(sc, d) for sc in sweep.get("scales", []) for d in sweep.get("distributions", [])]


SCALE_TEXT = {"both": "gyro and magnetometer", "gyro": "gyro only",
              "magnetometer": "magnetometer only"}


def existence_rows(s: dict[str, Any]) -> list[list[str]]:
    """H∞ existence failures per filter and γ over the sweep's logs, all factors summed per
    mismatch and distribution (fallbacks / updates), then the campaign's own H∞ runs."""
    sweep = s.get("sweep") or {}
    rows = []
    for name, entry in (s.get("filters") or {}).items():
        if "hinf_fallbacks" in entry:
            rows.append([f"{name} γ={_gamma_text(s.get('gamma_rad'))} (campaign)",
                         "campaign noise", _fallback_cell(name, entry),
                         str(entry.get("hinf_runs_with_fallbacks", tables.MISSING)),
                         entry.get("hinf_on_failure", tables.MISSING)])
    for scale, dist in _sweep_groups(sweep):
        for row in sweep.get("rows", []):
            cells = [c for c in sweep.get("cells", [])
                     if c["row"] == row and c["distribution"] == dist and c["scale"] == scale
                     and c.get("gamma_rad") is not None]
            if not cells:
                continue
            falls = sum(c["fallbacks"] for c in cells)
            per_factor = ", ".join(f"{c['factor']:g}×: {c['fallbacks']}" for c in cells)
            rows.append([row, f"sweep, {SCALE_TEXT.get(scale, scale)}, {dist}",
                         f"{falls}/{sum(c['updates'] for c in cells)}", per_factor,
                         "Kalman update for that step"])
    return rows


EXISTENCE_HEADER = ("filter", "noise", "failed / updates", "by factor (or runs hit)",
                    "what the filter then did")


def sweep_sections(s: dict[str, Any]) -> list[Section]:
    """One table per mismatch (scale) and noise shape: rows the sweep's filters (H∞ per
    γ), columns the factors; cells ``pitch / yaw RMSE (°)`` and the existence failures."""
    sweep = s.get("sweep") or {}
    factors = sweep.get("factors", [])
    out = []
    for scale, dist in _sweep_groups(sweep):
        mine = [c for c in sweep.get("cells", [])
                if c["distribution"] == dist and c["scale"] == scale]
        header = ["filter"] + [f"{f:g}× pitch / yaw (°)" for f in factors]
        rows = []
        for row in sweep.get("rows", []):
            cells = {c["factor"]: c for c in mine if c["row"] == row}
            line = [row]
            for f in factors:
                c = cells.get(f)
                if c is None or not c["logs"]:
                    line.append(tables.MISSING)
                    continue
                extra = f" [{c['fallbacks']} fb]" if c.get("fallbacks") else ""
                extra += f" ({c['diverged']} div)" if c.get("diverged") else ""
                line.append(f"{tables.num(c['rmse_pitch_deg'], '.3f')} / "
                            f"{tables.num(c['rmse_yaw_deg'], '.3f')}{extra}")
            rows.append(line)
        logs = {c["logs"] for c in mine}
        paired = "/".join(f"{c['paired_logs']}" for c in mine if c["row"] == rows[0][0]) \
            if rows else ""
        text = (f"True noise = factor × assumed on the {SCALE_TEXT.get(scale, scale)} "
                f"({dist}); {'/'.join(map(str, sorted(logs)))} log(s) per factor, every filter "
                "on the same logs and prior draws; the RMSE is over the logs every row "
                f"finished ({paired} per factor). " + MISMATCH_TEXT.get(scale, "") +
                " [n fb] = updates whose H∞ existence condition failed (then the Kalman update "
                "was used); (n div) = logs the row diverged on. γ=∞ rows are the Kalman "
                "twin's (srckf). A handful of logs per cell: a screen, not a ranking.")
        out.append(Section(f"Noise-mismatch sweep: {SCALE_TEXT.get(scale, scale)} ({dist})",
                           header, rows, text))
    return out


MISMATCH_TEXT = {
    "both": "Scaling both noises leaves the Kalman gain unchanged (only the prior becomes "
            "relatively tighter): the weakest mismatch.",
    "gyro": "The filters trust the gyro (and eq. 3's increments) too much: the gain on the "
            "magnetometer is too small.",
    "magnetometer": "The filters trust the magnetometer too much: its axial reading gets too "
                    "much gain, and the roll of eq. 7-8 (and so eq. 3's resolution) is noisier "
                    "than assumed.",
}


PAPER_TEXT = ("[Spin SR-CH∞KF] publishes no error numbers: its Fig. 5-8 are described in "
              "words, so the paper's column holds its statements (best / worst filter per "
              "angle), ours whether the paired ranking among the paper's five filters (UKF, "
              "CKF, SRCKF, SVD-CKF, SR-CH∞KF; the tables above also rank the EKF and UT-H∞) "
              "bears each out: reproduced only when the difference exceeds 2 standard errors "
              "of the paired difference. CKF "
              "and SRCKF are the same filter in exact arithmetic (the paper's difference "
              "between them is a numerical-stability claim; in double precision they agree "
              "to round-off here); SVD-CKF puts the same cubature points along the "
              "covariance's eigenvectors instead of its Cholesky columns, which differs only "
              "at third order on a nonlinear model.")


def flight_note(s: dict[str, Any]) -> str:
    """How the flight meets Table 2: the calibration's misses (a world whose calibration
    misses by more than its tolerance is refused), or, when the drag is given, the misses
    (the summary's ``flight.warning`` when one exceeds the tolerance)."""
    f = s.get("flight") or {}
    miss = f.get("target_miss") or {}
    cells = ", ".join(f"{key.removeprefix('target_').rsplit('_', 1)[0].replace('_', ' ')} "
                      f"{tables.num(v, '+.1f', 100.0)} %" for key, v in miss.items())
    if f.get("drag_calibrated"):
        return (f"Table 2's flight is met by the drag calibration (k = "
                f"{tables.num(f.get('drag_k_per_m'), '.4g')} /m; flown - target: {cells}; "
                f"tolerance {tables.num(f.get('calibration_tolerance'), 'g', 100.0)} %).")
    if not miss:
        return ""
    if f.get("warning"):
        return f"Warning: {f['warning']}."
    return (f"The drag is given (drag_k_per_m = {tables.num(f.get('drag_k_per_m'), 'g')} /m), "
            f"not calibrated: the flight differs from Table 2's by {cells}.")

HOW_TO_READ = (
    "Yaw is nearly unobservable from the axial field: the reading depends on it only through "
    "cos(D − β), stationary at β = D = 2.32° while the flight heads north (β ≈ 0) with a small "
    "crosswind drift, so the yaw error mostly keeps its launch prior plus the gyro's random "
    "walk until the geometry changes late in the flight; the smoother, using the late "
    "readings for the whole flight, does much better. Pitch is observed well except near the "
    "blind area, where ∂B_x/∂α → 0 as the axis lines up with the field. The gyro measures the "
    "spinning body's transverse rates: eq. 3 turns them into pitch and yaw rates with the roll "
    "of eq. 7-8, which each filter computes from the radial readings with its own pitch and "
    "yaw and uses as an exact input (the paper's structure). A roll error δ turns the rate "
    "vector by δ, leaking |ω⊥| sin δ into pitch and yaw that no filter's Q holds: in the blind "
    "area the radial field is a few percent of B, the roll error grows to tens of degrees "
    "(roll columns; the roll floor uses the true pitch and yaw) and every filter, and the "
    "smoother on the same model, comes out optimistic (ANEES above its band). The sigma-point "
    "filters' differences are small (errors.png writes the largest, differences.png draws "
    "them): at the sigma points' spread the model is close to linear, and the feedback "
    "through the roll amplifies round-off-sized differences in the blind area. SR-CH∞KF here "
    "keeps the Kalman gain and mean of each update and bounds the covariance by "
    "(P_KF⁻¹ − γ⁻²I)⁻¹, i.e. it adds about P_KF²/γ² per update: that acts on the poorly "
    "observed yaw and reaches the pitch through their correlation "
    "(benchmarks/spinning_hinf.py measures the σ increase). The inflated covariance raises "
    "the next gains, so the filter weights the magnetometer more, the opposite of what an "
    "underestimated magnetometer noise calls for; below the headline γ the existence "
    "condition fails on many updates (table above) and the estimate degrades.")


def _finite(v: Any) -> bool:
    return isinstance(v, float) and math.isfinite(v)


def prior_note(s: dict[str, Any]) -> str:
    """What the campaign's prior draws do to the ANEES (the yaw keeps its prior error)."""
    z = s.get("prior_draws_mean_sq") or {}
    if not _finite(z.get("yaw")):
        return ""
    return (f"This campaign's initial estimates were drawn with squared errors of "
            f"{z['pitch']:.2f} (pitch) and {z['yaw']:.2f} (yaw) times their prior variance on "
            "average (1 expected); since the yaw keeps its initial error until late in the "
            "flight, the filters' NEES carries that draw over most of the flight (nees.png).")


def hinf_verdict(s: dict[str, Any]) -> str:
    """A sentence from the sweeps: SR-CH∞KF's best finite γ against SRCKF, per mismatch,
    distribution and factor."""
    sweep = s.get("sweep") or {}
    parts = []
    for scale, dist in _sweep_groups(sweep):
        cells = [c for c in sweep.get("cells", []) if c["distribution"] == dist
                 and c["scale"] == scale and c["logs"]]
        for f in sweep.get("factors", []):
            base = next((c for c in cells if c["factor"] == f and c["row"] == "srckf"), None)
            hinf = [c for c in cells if c["factor"] == f and c["filter"] == "srchinf"
                    and c["gamma_rad"] is not None and _finite(c["rmse_pitch_deg"])]
            if base is None or not hinf or not _finite(base["rmse_pitch_deg"]):
                continue
            best = min(hinf, key=lambda c: c["rmse_pitch_deg"] + c["rmse_yaw_deg"])
            dp = 100 * (best["rmse_pitch_deg"] / base["rmse_pitch_deg"] - 1)
            dy = 100 * (best["rmse_yaw_deg"] / base["rmse_yaw_deg"] - 1)
            parts.append(f"{SCALE_TEXT.get(scale, scale)}, {dist} {f:g}×: best {best['row']} "
                         f"{dp:+.1f} % pitch, {dy:+.1f} % yaw")
    if not parts:
        return ""
    return ("SR-CH∞KF's best finite γ against SRCKF in the sweeps (RMSE change over few logs, "
            "no significance; negative = H∞ better): " + "; ".join(parts) + ".")


def sections(s: dict[str, Any]) -> list[Section]:
    """The report's sections (module docstring)."""
    head, *decision = decision_sections(s) or [None]
    out = [x for x in (head, Section("Results", RESULTS.header, result_rows(s),
                                     _results_text(s)), *decision) if x is not None]
    out += [
        Section("Paper vs ours", ("", "paper", "ours"), paper_rows(s),
                " ".join(t for t in (PAPER_TEXT, flight_note(s)) if t)),
        Section("H∞ existence check", EXISTENCE_HEADER, existence_rows(s),
                "Eq. 25/33's condition λmax(P_KF) < γ² (estimators.hinf) per update.")]
    out += sweep_sections(s)
    out.append(Section("How to read this", text=" ".join(filter(None, [
        HOW_TO_READ, prior_note(s), hinf_verdict(s)]))))
    return out


def _warning(s: dict[str, Any]) -> str:
    w = (s.get("flight") or {}).get("warning")
    return f"warning: {w}" if w else ""


def text_table(s: dict[str, Any]) -> str:
    """The results table as aligned plain text that fits the terminal (the ANEES band
    and the full row names in the notes below it), then the failure reasons."""
    header = ["estimator", "pitch", "yaw", "roll", "blind", "ANEES", "in band",
              "verdict", "H∞ fb", tables.EPOCH_TIME, tables.TERMINAL_HEADERS["diverged runs"]]
    rows = [[r[i] for i in (0, 2, 4, 5, 6, 7, 8, 9, 11, 12, 13)] for r in result_rows(s)]
    for row in rows:
        row[0] = row[0].replace(" (true pitch, yaw)", "*").replace(" smoother", "")
        row[5] = row[5].split(" [")[0]
    notes = ["errors: RMSE in degrees over all epochs and runs; roll: outside the blind area, "
             "blind: roll inside it; roll floor*: roll from the magnetometer with the true "
             "pitch and yaw.", _warning(s), tables.band_note(s), smoother_cost(s),
             *tables.failure_notes(s)]
    return "\n".join([tables.plain_table(header, rows), *(tables.wrap(n) for n in notes if n),
                      "", decision_text(s)])


TUM_NOTE = (f"{tum.ATTITUDE_NOTE}, navigation frame North-Up-East, C_nb = Ry(yaw) Rz(pitch) "
            "Rx(roll); the estimators' roll: implied by their pitch and yaw (eq. 7-8); "
            "poses at the filter epochs")
TUM_COV = ("t, then the estimator's 2 x 2 covariance of [pitch, yaw] row-major (rad²; the "
           "roll it implies has none)")


def _track(o: RunOutcome, name: str) -> tuple[Array, Array, Array | None]:
    """``(zero position, q_nb, pitch/yaw covariance)`` of ``name`` on run ``o``."""
    from slam.kinds.spinning.truth import attitude_dcm

    if name == "truth":
        angles, cov = o.truth, None
    else:
        tr = o.tracks[name]
        angles, cov = np.column_stack([tr.means, tr.roll]), tr.covs  # type: ignore[attr-defined]
    q = dcm_to_q(attitude_dcm(angles[:, 0], angles[:, 1], angles[:, 2]))
    return np.zeros((len(q), 3)), q, cov


write_tum_files, tum_links = tum.report_files(_track, TUM_NOTE, TUM_COV,
                                              "attitude (zero position)")
"""The TUM files and covariance sidecars of every tracked run (module docstring) and the
report's entries for them."""


REPORT = KindReport("spinning-projectile attitude campaign", sections,
                    Deferred("slam.kinds.spinning.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The ``spinning`` kind's report."""
