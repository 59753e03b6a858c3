"""The IMU + GNSS log kind: readers, epochs cut at the fixes, frames and units, the filters
and the GTSAM smoother on a synthetic log, scores, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.ins_log.run import DROPPED, USED, WITHHELD, alignment, fix_roles, run_once
from slam.kinds.ins_log.synthetic import write_log
from slam.kinds.ins_log.world import open_log, parse_outage, reads
from slam.kinds.recorded.log import LogFormatError


@pytest.fixture(scope="module")
def turn_log(tmp_path_factory):
    return write_log(tmp_path_factory.mktemp("log"))


def test_reads_the_paths_it_owns():
    assert reads("kitti") and reads("a/b.CSV") and not reads("victoria_park.txt")


def test_epochs_hold_exactly_the_time_between_fixes(turn_log):
    w = open_log(turn_log)
    log, ep = w.log, w.log.epochs
    assert log.n_fixes == 90
    for i in range(1, log.n_fixes):
        g, f, h = ep.of(i)
        assert h.sum() == pytest.approx(log.fix_t[i] - log.fix_t[i - 1], abs=1e-12)
        assert len(h) > 50
    assert ep.of(0)[2].size == 0


def test_a_reading_straddling_a_fix_is_split():
    from slam.kinds.ins_log.log import InsLog

    t = np.array([0.0, 1.0, 2.0, 3.0])
    rows = np.arange(4.0)[:, None] * np.ones(3)
    log = InsLog(t, rows, -rows, np.array([0.0, 1.5, 3.0]), np.zeros((3, 3)), None,
                 np.ones((3, 3)), None, None, "mem", "mem")
    g, f, h = log.epochs.of(1)
    np.testing.assert_array_equal(h, [1.0, 0.5])
    np.testing.assert_array_equal(g[:, 0], [1.0, 2.0])  # reading k covers (t[k-1], t[k]]
    g, f, h = log.epochs.of(2)
    np.testing.assert_array_equal(h, [0.5, 1.0])
    np.testing.assert_array_equal(f[:, 0], [-2.0, -3.0])


def test_filters_and_smoother_follow_the_turn_at_held_out_fixes(turn_log):
    w = open_log(turn_log, holdout=5, outages=[(70.0, 10.0)])
    roles = fix_roles(w.log, w.scoring)
    assert roles[5] == WITHHELD and roles[71] == DROPPED and roles[61] == USED
    o = run_once(w, 0, None, ["ekf", "srckf"])
    for name in ("ekf", "srckf", "gtsam-online", "gtsam"):
        s = o.scores[name]
        assert not s.diverged, s.failure
        assert s.values["heldout"]["rmse_m"] < 0.05, name
        assert s.values["outages"][0]["drift_m"] < 2.0, name
    ekf, srckf = (o.scores[n].values["heldout"]["rmse_m"] for n in ("ekf", "srckf"))
    assert abs(ekf - srckf) < 0.01
    from slam.kinds.ins_log.run import summarize
    from slam.nulls import unexplained_nulls

    summary = summarize(w, [o], ["ekf", "srckf"], 1, 0)
    assert unexplained_nulls(summary) == []
    assert summary["best_filter_over_online"]["filter"] in ("ekf", "srckf")


def test_summary_without_holdout_explains_its_nulls(turn_log):
    from slam.kinds.ins_log.run import summarize
    from slam.nulls import unexplained_nulls

    w = open_log(turn_log)
    o = run_once(w, 0, None, ["ekf"], reference=False)
    assert unexplained_nulls(summarize(w, [o], ["ekf"], 1, 0)) == []


def test_fullwidth_and_arabic_digits_are_refused(tmp_path):
    for tok in ("１２", "١٢", "1_0"):
        path = _broken(tmp_path, lambda ls, tok=tok: ls[:5] + [
            ",".join([*ls[5].split(",")[:2], tok, *ls[5].split(",")[3:]])] + ls[6:])
        with pytest.raises(LogFormatError, match="turn.csv:6: gy"):
            open_log(path)


def test_ned_frd_and_degrees_give_the_same_estimates(tmp_path):
    a = open_log(write_log(tmp_path, "enu"), holdout=4)
    b = open_log(write_log(tmp_path, "ned", ned=True, deg=True), holdout=4)
    np.testing.assert_allclose(a.log.fix_p, b.log.fix_p, atol=1e-9)
    np.testing.assert_allclose(a.log.gyro, b.log.gyro, atol=1e-12)
    oa = run_once(a, 0, None, ["ekf"], reference=False)
    ob = run_once(b, 0, None, ["ekf"], reference=False)
    ea = oa.scores["ekf"].values["heldout"]["error_m"]
    eb = ob.scores["ekf"].values["heldout"]["error_m"]
    np.testing.assert_allclose(ea, eb, atol=1e-6)


def test_alignment_levels_and_heads_the_turn(turn_log):
    w = open_log(turn_log)
    a, x0, P0, how = alignment(w.log, fix_roles(w.log, w.scoring))
    assert a == 1 and "heading" in how
    from nav.euler import q_to_euler_zyx

    roll, pitch, yaw = q_to_euler_zyx(x0[6:10])
    assert abs(pitch) < 1e-6 and abs(roll) < 0.03  # the centripetal tilt a/g
    assert yaw == pytest.approx(0.01, abs=0.002)  # the chord's heading at mid-second


@pytest.mark.parametrize("text", ["30", "a:b", "1:2:3", "-1:5", "5:0", "nan:3", "1:inf"])
def test_outage_syntax(text):
    with pytest.raises(ValueError, match="--outage"):
        parse_outage(text)


def _broken(tmp_path, edit, sidecar=None):
    path = write_log(tmp_path, duration=10.0)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")
    if sidecar:
        side = path.with_suffix(".toml")
        side.write_text(sidecar(side.read_text()))
    return path


@pytest.mark.parametrize(("edit", "sidecar", "match"), [
    (lambda ls: ls[:1] + [ls[2]] + [ls[1]] + ls[3:], None, r"turn.csv:3: row time"),
    (lambda ls: [ls[0].replace("gz", "gq")] + ls[1:], None, "unknown column 'gq'"),
    (lambda ls: [ls[0].replace(",gz", "")] + [",".join(x.split(",")[:3] + x.split(",")[4:])
                                              for x in ls[1:]], None, "missing column gz"),
    (lambda ls: ls[:5] + [ls[5].replace(",", ",1e999,", 1)] + ls[6:], None, ":6: 7 fields|:6:"),
    (lambda ls: ls[:5] + [ls[5].replace(",", ",١٢,", 1)[:-0 or None]] + ls[6:], None, ":6:"),
    (lambda ls: ls, lambda s: s.replace('"ENU"', '"XYZ"'), r"\[frames\] navigation"),
    (lambda ls: ls, lambda s: s.replace('body = "FLU"', 'body = "FRD"'), r"ENU/FLU or NED/FRD"),
    (lambda ls: ls, lambda s: s.replace("arw_deg_sqrt_h = 0.05", "arw_deg_sqrt_h = -1"),
     r"\[imu\] arw_deg_sqrt_h"),
    (lambda ls: ls, lambda s: s.replace("[site]", "[site"), "not valid TOML"),
    *[(lambda ls: ls, lambda s, v=v: s.replace("[filters]\n",
                                              f"[filters]\npreintegration_fixes = {v}\n"),
       r"\[filters\] preintegration_fixes: = .*integer in \[1, 1000\]")
      for v in ("0", "1001", "2.5", "true", '"20"')],
    (lambda ls: ls[:3], None, "GNSS fixes"),
])
def test_bad_input_names_file_line_or_key(tmp_path, edit, sidecar, match):
    with pytest.raises(LogFormatError, match=match):
        open_log(_broken(tmp_path, edit, sidecar))


def test_missing_sidecar_and_bad_options(tmp_path):
    path = write_log(tmp_path, duration=10.0)
    with pytest.raises(LogFormatError, match="--holdout"):
        open_log(path, holdout=1)
    with pytest.raises(LogFormatError, match="starts after"):
        open_log(path, outages=[(100.0, 5.0)])
    path.with_suffix(".toml").unlink()
    with pytest.raises(LogFormatError, match="sidecar"):
        open_log(path)


def test_truth_columns_give_the_usual_scores(turn_log):
    from slam.kinds.ins_log.report import text_table
    from slam.kinds.ins_log.run import summarize

    w = open_log(turn_log, holdout=5)
    assert w.log.truth_p is not None
    o = run_once(w, 0, None, ["ekf"])
    t = o.scores["ekf"].values["truth"]
    assert t["epochs"] == w.log.n_fixes - 1 and t["rmse_m"] < 0.05
    assert t["nees_epochs"] == t["epochs"]
    assert "truth" in text_table(summarize(w, [o], ["ekf"], 1, 0))


def test_gnss_velocity_fixes_are_six_dimensional_updates(tmp_path):
    w = open_log(write_log(tmp_path, velocity=True), holdout=5)
    assert w.log.fix_v is not None and w.log.fix_sv[0, 0] == 0.05
    o = run_once(w, 0, None, ["ekf", "srckf"], reference=True)
    for name in ("ekf", "srckf", "gtsam-online"):
        assert o.scores[name].values["heldout"]["rmse_m"] < 0.05, name
    assert o.scores["ekf"].values["nis"]["windows"] == 1  # 71 updates: one window of 50


def test_a_stated_lever_arm_is_used(tmp_path):
    arm = (2.0, 0.5, 1.0)
    with_arm = open_log(write_log(tmp_path, "arm", lever_arm=arm), holdout=5)
    side = tmp_path / "arm.toml"
    side.write_text(side.read_text().replace(f"lever_arm_m = {list(arm)}\n", ""))
    without = open_log(tmp_path / "arm.csv", holdout=5)
    rmse = {}
    for label, w in (("with", with_arm), ("without", without)):
        o = run_once(w, 0, None, ["ekf"])
        rmse[label] = (o.scores["ekf"].values["truth"]["rmse_m"],
                       o.scores["gtsam"].values["truth"]["rmse_m"],
                       o.scores["ekf"].values["heldout"]["rmse_m"],
                       o.scores["gtsam-online"].values["heldout"]["rmse_m"])
    assert max(rmse["with"]) < 0.05  # the IMU against truth, the antenna against the fixes
    assert rmse["without"][0] > 1.0  # the antenna's offset is taken for the IMU's


def test_an_imu_gap_is_held_and_counted(tmp_path):
    path = write_log(tmp_path)
    lines = path.read_text().splitlines()
    keep = [lines[0]] + [ln for ln in lines[1:]
                         if not 40.0 < float(ln.split(",")[0]) < 42.5 or ln.split(",")[7]]
    path.write_text("\n".join(keep) + "\n")
    w = open_log(path, holdout=5)
    assert w.log.gaps >= 2  # 40 -> 41 and 41 -> 42 s: one reading held over each second
    o = run_once(w, 0, None, ["ekf"], reference=False)
    assert o.scores["ekf"].values["heldout"]["rmse_m"] < 0.05  # constant readings: exact
