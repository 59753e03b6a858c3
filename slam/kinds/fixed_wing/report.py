"""Tables and sections of a ``fixed-wing`` campaign report ([Fixed-wing EA-UKF]).

* Decision: the headline, the paired rankings (INS position, attitude, heading) and the
  filters' settings (:mod:`slam.render.decision`), then the paper's orderings tested;
* Table 1, paper vs ours: the paper's UKF and CKF rows next to our INS-UKF and INS-CKF,
  then INS-SRCKF, INS-EKF, the smoother and the EA filters (heading only);
* Results: attitude RMSE, position RMSE, consistency (ANEES, epochs in band, verdict),
  NIS, time per cycle (filters) and per run (every estimator), diverged runs;
* Turns: RMS roll / pitch / heading error in turns, while accelerating outside turns and in
  steady flight, with the accelerometer gravity rule's own error on the error-free
  readings (the prediction);
* How to read this.

Files: ``truth.tum`` and ``<estimator>.tum`` with ``<estimator>.cov.txt`` of every tracked
run (run 0; every run with ``slam run --tum all``: :mod:`slam.render.tum`): the INS
filters and the smoother as full poses at the INS epochs, the EA filters with zero
position at the EA epochs.
"""

from __future__ import annotations

from typing import Any

from slam.kind import Deferred
from slam.render import tum
from slam.render.decision import (
    decision_sections,
    decision_text,
    ordering_rows,
    ordering_section,
)
from slam.render.document import KindReport, Section
from slam.render.tables import (
    DIVERGED,
    EPOCH_TIME,
    MISSING,
    RUN_TIME,
    TERMINAL_HEADERS,
    Column,
    Table,
    band_note,
    consistency_columns,
    consistency_rule,
    estimator_entries,
    failure_notes,
    num,
    plain_table,
    value,
    wrap,
)
from slam.results import REFERENCE

T1 = ("longitude_m", "latitude_m", "east_velocity_mps", "north_velocity_mps", "heading_deg")
T1_HEADER = ("row", "longitude (m)", "latitude (m)", "east vel (m/s)", "north vel (m/s)",
             "heading (°)")


def _t1(values: dict[str, Any]) -> list[str]:
    return [num(values.get(k), ".2f") for k in T1]


def table1_rows(s: dict[str, Any]) -> list[list[str]]:
    """The paper's rows beside ours (mean |error| over epochs and runs)."""
    paper = (s.get("paper") or {}).get("table1") or {}
    rows = []
    for name, e in estimator_entries(s):
        ours = [f"{name} (ours)", *_t1(e.get("table1") or {})]
        base = name.removeprefix("ins-")
        if name.startswith("ins-") and base in paper:
            rows.append([f"{base.upper()} (paper)", *_t1(paper[base])])
        rows.append(ours)
    return rows


def _att(axis: str) -> Column:
    return Column(f"{axis} RMSE (°)",
                  lambda n, e: num((e.get("att_rmse_deg") or {}).get(axis), ".3f"))


def _cycle(name: str, e: dict[str, Any]) -> str:
    """A filter's time per cycle (the smoother has no cycles: its cost is per run)."""
    if name == REFERENCE:
        return "per run only"
    return num(e.get("time_per_cycle_s"), ".2f", 1e3)


RESULTS = Table((
    Column("estimator", lambda n, e: n), _att("roll"), _att("pitch"), _att("heading"),
    Column("pos RMSE (m)", value("pos_rmse_m", ".3f")),
    *consistency_columns(), Column("NIS/dof", value("nis_mean", ".2f")),
    Column("ms/cycle", _cycle), Column("s/run", value("time_per_run_s", ".2f")), DIVERGED))


def _split(e: dict[str, Any], seg: str, axis: str) -> str:
    return num(((e.get("turn_split_rmse_deg") or {}).get(seg) or {}).get(axis), ".2f")


SEGMENTS = (("turns", "turn"), ("accelerating", "accel."), ("steady", "steady"))
TURN_HEADER = ("estimator", *(f"{a} {short} (°)" for a in ("roll", "pitch", "heading")
                              for _, short in SEGMENTS))


def turn_rows(s: dict[str, Any]) -> list[list[str]]:
    """RMS errors per segment and estimator, then the gravity rule's own."""
    cells = [(a, seg) for a in ("roll", "pitch", "heading") for seg, _ in SEGMENTS]
    rows = [[n, *(_split(e, seg, a) for a, seg in cells)] for n, e in estimator_entries(s)]
    acc = s.get("accelerometer_angle_error_deg") or {}
    for stat in ("rms", "max") if acc else ():
        rows.append([f"gravity rule, error-free ({stat.upper() if stat == 'rms' else stat})",
                     *(num(((acc.get(seg) or {}).get(a) or {}).get(stat), ".2f")
                       for a, seg in cells)])
    return rows


def segment_note(s: dict[str, Any]) -> str:
    """The epochs behind each segment's RMS, per estimator family (EA filters at the
    accelerometer/magnetometer epochs, the GNSS-aided ones at theirs)."""
    seen: dict[tuple, list[str]] = {}
    for name, e in estimator_entries(s):
        sp = e.get("turn_split_rmse_deg") or {}
        counts = tuple((sp.get(seg) or {}).get("epochs") for seg, _ in SEGMENTS)
        if any(c is not None for c in counts):
            seen.setdefault(counts, []).append(name)
    if not seen:
        return ""
    parts = [f"{', '.join(names)}: " + " / ".join(MISSING if c is None else str(c)
                                                 for c in counts)
             for counts, names in seen.items()]
    empty = any(c == 0 for counts in seen for c in counts)
    return ("Epochs per run in turns / accelerating / steady: " + "; ".join(parts) + "."
            + (" A segment with no epoch has no RMS (—)." if empty else ""))


def _ratio(a: Any, b: Any) -> str:
    ok = all(isinstance(v, int | float) and v > 0 for v in (a, b))
    return f"{a / b:.1f}×" if ok else MISSING


def turn_verdict(s: dict[str, Any]) -> str:
    """Per EA filter, in words: the roll RMS in turns and the pitch RMS while accelerating
    against steady flight and against the gravity rule's own error (the prediction); a
    segment without epochs is said to be empty instead."""
    acc = s.get("accelerometer_angle_error_deg") or {}
    has = {seg: (acc.get(seg) or {}).get("epochs") != 0 for seg in ("turns", "accelerating")}
    if acc and not any(has.values()):
        return ("Gravity from the accelerometer: the flight has no epoch in a turn or "
                "accelerating (epochs 0), so there is nothing to split.")
    parts = []
    for name, e in estimator_entries(s):
        if not name.startswith("ea-"):
            continue
        sp = e.get("turn_split_rmse_deg") or {}
        steady = sp.get("steady") or {}
        said = [f"{what} RMS {num(v, '.2f')}° {where} vs {num(steady.get(axis), '.2f')}° "
                f"steady ({_ratio(v, steady.get(axis))})"
                for seg, axis, what, where in (("turns", "roll", "roll", "in turns"),
                                               ("accelerating", "pitch", "pitch",
                                                "accelerating"))
                if has[seg] for v in [(sp.get(seg) or {}).get(axis)]]
        parts.append(f"{name}: " + ", ".join(said))
    if not parts:
        return ""
    rule = [f"{num(r.get('rms'), '.2f')}° RMS (max {num(r.get('max'), '.2f')}°) in {axis} "
            f"{where}" for seg, axis, where in (("turns", "roll", "during turns"),
                                               ("accelerating", "pitch", "while accelerating"))
            if has[seg] for r in [((acc.get(seg) or {}).get(axis) or {})]]
    empty = [seg for seg, ok in has.items() if not ok]
    return ("Gravity from the accelerometer: " + "; ".join(parts) + ". The gravity rule "
            "alone, on error-free readings, is off by " + " and by ".join(rule) + "."
            + (f" No epoch {' or '.join(WHERE[seg] for seg in empty)}." if empty else ""))


WHERE = {"turns": "in a turn", "accelerating": "accelerating outside turns"}


def paper_verdict(s: dict[str, Any]) -> str:
    """The paper's UKF/CKF ratio per Table 1 column beside ours (INS-UKF / INS-CKF)."""
    paper = (s.get("paper") or {}).get("table1") or {}
    filters = s.get("filters") or {}
    ours_u = (filters.get("ins-ukf") or {}).get("table1") or {}
    ours_c = (filters.get("ins-ckf") or {}).get("table1") or {}
    pu, pc = paper.get("ukf") or {}, paper.get("ckf") or {}
    if not (ours_u and ours_c and pu and pc):
        return ""
    ours = [_q(ours_u.get(k), ours_c.get(k)) for k in T1]
    cells = [f"{k.split('_')[0]} {_ratio(pu.get(k), pc.get(k))} vs {num(r, '.4f')}"
             for k, r in zip(T1, ours)]
    known = [r for r in ours if r is not None]
    if known and all(r > 1.05 for r in known):
        what = "CKF is more accurate than UKF in every column, as in the paper."
    elif known and all(abs(r - 1.0) < 0.01 for r in known):
        what = ("The paper's CKF advantage is not reproduced: the two filters' errors agree "
                "within 1 % in every column.")
    else:
        what = "The paper's ordering is not reproduced column by column."
    return "UKF / CKF mean-error ratio, paper vs ours: " + ", ".join(cells) + ". " + what


def _q(a: Any, b: Any) -> float | None:
    ok = all(isinstance(v, int | float) and v > 0 for v in (a, b))
    return a / b if ok else None


def flight_text(s: dict[str, Any]) -> str:
    f = s.get("flight") or {}
    sp, h = f.get("speed_mps") or [None, None], f.get("height_m") or [None, None]
    return (f"{s.get('runs', '?')} runs of {num(s.get('duration_s'), 'g')} s; IMU "
            f"{num(s.get('imu_rate_hz'), 'g')} Hz, EA updates {num(s.get('ea_rate_hz'), 'g')} "
            f"Hz, GNSS {num(s.get('gnss_rate_hz'), 'g')} Hz. Flight: speed {num(sp[0], '.1f')}-"
            f"{num(sp[1], '.1f')} m/s, height {num(h[0], '.0f')}-{num(h[1], '.0f')} m, largest "
            f"bank {num(f.get('max_bank_deg'), '.1f')}°, {num(f.get('turn_time_fraction'), '.0%')}"
            " of the time in turns.")


HOW_TO_READ = (
    "Table 1 of the paper gives mean errors of its UKF and CKF; its position and velocity "
    "columns can only come from the INS/UQ filter, so they are set beside our INS-UKF and "
    "INS-CKF (mean absolute error over the epochs and the fifteen runs, longitude = east and "
    "latitude = north error in metres). The paper names no aiding sensor, flight, sensor "
    "grade or noise level: ours are in the world file, and nothing is tuned to its numbers. "
    "The EA filters carry no position; their heading is from the magnetometer. "
    "RMSE are over all epochs and runs. ms/cycle: a filter's wall-clock per predict + update cycle "
    "inside the campaign's workers (EA cycles are one accelerometer/magnetometer epoch, INS "
    "cycles one GNSS period of IMU samples, cut at whole fractions of it not above 1 s when "
    "fixes come less than once a second; the INS filters and the smoother are scored at "
    "those epochs, predictions between fixes included); s/run: every estimator's wall-clock "
    "per run (the smoother's solve). The gravity rule's pitch is right "
    "in turns (a coordinated turn keeps the specific force in the body's x-z plane), so the "
    "EA filters' pitch error there comes through the filter - our reading: the roll error "
    "and the bias estimates that absorbed the roll-measurement error enter the Euler-rate "
    "kinematics (θ̇ = q cos φ − r sin φ with the turn rate r). The smoother's bias is "
    "GTSAM's random walk while the simulated drifts are first-order Markov (T_a, T_b in the "
    "world file); with correlation times far beyond the run it passes a χ² NEES test "
    "(tests), so its optimistic verdict here is that model mismatch. ")


def covariance_note(s: dict[str, Any]) -> str:
    """The runs whose smoother marginals GTSAM could not factor (no smoother NEES there)."""
    ref = (s.get("reference") or {}).get(REFERENCE) or {}
    n = ref.get("no_covariance_runs")
    if not n:
        return ""
    return (f"The smoother's marginal covariances failed on {n} run(s) "
            f"({'; '.join(ref.get('no_covariance_reasons') or [])}): its errors are scored, "
            "its NEES is not.")


def sections(s: dict[str, Any]) -> list[Section]:
    """The report's sections (module docstring)."""
    paper = s.get("paper") or {}
    order = ordering_section(s, "[Fixed-wing EA-UKF] Table 1: its CKF beats its UKF in every "
                             "column (1.9-3.1×; the position/velocity columns read as the "
                             "INS filters'); its conclusion: the INS/UQ-CKF beats the "
                             "EA-UKF.")
    return [
        *decision_sections(s),
        *([order] if order is not None else []),
        Section("Table 1: paper vs ours", T1_HEADER, table1_rows(s),
                f"{paper.get('source', '')}. {flight_text(s)} {paper_verdict(s)}"),
        Section("Results", RESULTS.header, RESULTS.rows(s), consistency_rule()),
        Section("Turns and accelerations: gravity from the accelerometer", TURN_HEADER,
                turn_rows(s),
                " ".join(t for t in (turn_verdict(s), segment_note(s)) if t)),
        Section("How to read this",
                text=HOW_TO_READ + " ".join([*failure_notes(s), covariance_note(s)])),
    ]


def text_table(s: dict[str, Any]) -> str:
    """Table 1 (paper beside ours) and the consistency columns, for the terminal."""
    t1 = plain_table(["row", "lon m", "lat m", "vE m/s", "vN m/s", "head °"], table1_rows(s))
    rows = [[r[0], r[1], r[2], r[3], r[4], r[5].split(" [")[0], r[6], r[7],
             MISSING if r[0] == REFERENCE else r[9], r[10], r[11]] for r in RESULTS.rows(s)]
    res = plain_table(["estimator", "roll°", "pitch°", "head°", "pos m", "ANEES",
                       "in band", "verdict", EPOCH_TIME, RUN_TIME,
                       TERMINAL_HEADERS["diverged runs"]], rows)
    notes = [paper_verdict(s), turn_verdict(s), *failure_notes(s), covariance_note(s)]
    order = [[r[0], o["metric"], *r[2:5], r[6]]
             for r, o in zip(ordering_rows(s), s.get("paper_ordering") or [])]
    runs = {str(o.get("runs")) for o in s.get("paper_ordering") or []}
    tested = ["", f"The paper's orderings (paired over {'/'.join(sorted(runs))} runs; ΔMSE = "
              "claimed better − worse):",
              plain_table(["claim", "metric", "RMSE", "ΔMSE ± s.e.", "z", "verdict"],
                          order)] if order else []
    return "\n".join([t1, "", res, wrap("(RMSE in degrees over all epochs and runs; position "
                                          "in m; the smoother's cost per run only)"),
                      wrap(band_note(s)), *[wrap(n) for n in notes if n], *tested, "",
                      decision_text(s)])


POSE_NOTE = ("x, y: metres east/north of the start point, z: height (m); q = q_nb (body "
             "forward-left-up to ENU); poses at the INS epochs")
EA_NOTE = ("attitude only: the position columns are zero (the EA filters estimate no "
           "position); q = q_nb (body forward-left-up to ENU) from the filter's Z-Y-X Euler "
           "angles; poses at the EA epochs, truth.tum's at the INS epochs")
POSE_COV = ("t, then the 6 x 6 covariance of [position (m, ENU), attitude rotation vector "
            "(rad, body frame: q = q̂ ⊗ Exp(δθ))] row-major")
EA_COV = "t, then the 3 x 3 covariance of [roll, pitch, yaw] row-major (rad², Z-Y-X)"


def _ea(name: str) -> bool:
    return name.startswith("ea-")


_TRACK, _TIMES = tum.pose_track(lambda o: (o.truth[:, :3], o.truth[:, 3:7]))
write_tum_files, tum_links = tum.report_files(
    _TRACK, lambda n: EA_NOTE if _ea(n) else POSE_NOTE, lambda n: EA_COV if _ea(n) else POSE_COV,
    lambda n: "attitude (zero position)" if _ea(n) else "pose", _TIMES)
"""The TUM files and covariance sidecars of every tracked run (module docstring) and the
report's entries for them."""


REPORT = KindReport("fixed-wing UAV attitude campaign ([Fixed-wing EA-UKF])", sections,
                    Deferred("slam.kinds.fixed_wing.figures:figures"), text_table,
                    write_tum_files, tum_links)
"""The ``fixed-wing`` kind's report."""
