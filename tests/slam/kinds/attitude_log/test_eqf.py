"""Recorded attitude logs (GTSAM's EqFdata.csv layout) through ``slam run --log``: the first
12 s of the wheel's file end to end (filters against the truth and the AHRS smoother, the
filters' settings printed), ``--log eqf`` resolved to the wheel's file, and malformed
files refused in one line naming the file, the line and the rule (exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import gtsam
import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from slam.kinds.attitude_log.log import parse_attitude_log, read_attitude_log
from slam.kinds.recorded.log import LogFormatError
from slam.logs import resolve_log
from slam.nulls import unexplained_nulls

EQF = Path(gtsam.findExampleDataFile("EqFdata.csv"))
ROWS = 2401  # 12 s at 200 Hz


@pytest.fixture(scope="module")
def lines() -> list[str]:
    return EQF.read_text(encoding="utf-8").splitlines()


@pytest.fixture(scope="module")
def short(tmp_path_factory, lines) -> Path:
    path = tmp_path_factory.mktemp("eqf") / "eqf6s.csv"
    path.write_text("\n".join(lines[:ROWS + 1]) + "\n", encoding="utf-8")
    return path


def test_the_reader_reads_the_wheels_file_layout(lines):
    log = parse_attitude_log("\n".join(lines[:ROWS + 1]), "eqf.csv")
    assert log.n_rows == ROWS and log.n_sensors == 2
    assert log.seen[:, 0].sum() == len(range(2, ROWS, 3)) and log.seen[2, 0]
    np.testing.assert_allclose(np.linalg.norm(log.body[log.seen], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(log.arw, np.radians(0.01), rtol=1e-12)
    assert log.epochs[0] == 0 and log.epochs[-1] == ROWS - 1


def test_slam_run_on_an_eqf_log(short, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", "--log", str(short), "--filters",
                                             "ekf,srckf", "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "gtsam (smoother)" in res.output
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert (s["kind"], s["rows"], s["sensors"]) == ("recorded-attitude", ROWS, 2)
    ekf, srckf, ref = s["filters"]["ekf"], s["filters"]["srckf"], s["reference"]["gtsam"]
    for e in (ekf, srckf, ref):
        assert not e["diverged"] and 0.0 < e["att_rmse_deg"] < 5.0, e
        assert e["anees_bounds_95"][0] < 1.0 < e["anees_bounds_95"][1]
    # the MEKF and the SRCKF agree closely on this nearly linear problem
    assert abs(ekf["att_rmse_after_10s_deg"] - srckf["att_rmse_after_10s_deg"]) < 0.05
    assert abs(ekf["att_final_deg"] - srckf["att_final_deg"]) < 0.05
    assert srckf["att_rmse_to_smoother_after_10s_deg"] < 1.0  # 0.56 measured
    assert (srckf["settings"], srckf["settings_text"]) == ({}, "") and srckf["nis_updates"] > 800
    assert unexplained_nulls(s) == []
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "## Settings" in md and "P0 = diag(0.1 I3 rad², 0.01 I3 rad²/s²)" in md


def test_log_eqf_is_the_wheels_file_and_the_kind_is_recognised_by_the_header(short):
    kind, path = resolve_log("eqf")
    assert kind.name == "recorded-attitude" and path == EQF
    assert resolve_log(str(short))[0].name == "recorded-attitude"
    victoria = gtsam.findExampleDataFile("victoria_park.txt")
    assert resolve_log(victoria)[0].name == "recorded-log"


def _set(L: list[str], i: int, j: int, tok: str) -> list[str]:
    row = L[i].split(",")
    row[j] = tok
    return L[:i] + [",".join(row)] + L[i + 1:]


BAD = [
    (lambda L: L[:1], "needs at least 2 rows"),
    (lambda L: [L[0].replace("q_w,", "qw,")] + L[1:], "missing column(s) q_w"),
    (lambda L: [L[0] + ",t"] + [r + ",0" for r in L[1:]], "column 't' appears twice"),
    (lambda L: L[:5] + [L[5].rsplit(",", 1)[0]] + L[6:], ":6: 38 fields; the header names 39"),
    (lambda L: _set(L, 3, 0, "abc"), ":4: field 1: 'abc' is not a number"),
    (lambda L: L[:3] + [L[2]] + L[4:], ":4: t must be strictly increasing"),
    (lambda L: _set(L, 3, 1, "inf"), ":4: q_w = inf: must be a finite number"),
    (lambda L: _set(L, 3, 1, "0.5"), ":4: q_w..q_z: not a unit quaternion"),
    (lambda L: _set(L, 3, 21, "NaN"), ":4: y_*_0: all three given (finite) or all NaN"),
    (lambda L: [L[0]] + [",".join(r.split(",")[:15] + ["-1"] + r.split(",")[16:])
                         for r in L[1:]], "std_w_* and std_b_* must be > 0"),
    (lambda L: [L[0]] + [",".join(r.split(",")[:15] + ["1e-300"] + r.split(",")[16:])
                         for r in L[1:]], "their squares must not underflow"),
    (lambda L: [L[0].replace("d_x_1", "dx1")] + L[1:], "sensor 1: missing column(s) d_x_1"),
]


@pytest.mark.parametrize(("mutate", "message"), BAD)
def test_malformed_logs_exit_2_with_one_line(lines, tmp_path, mutate, message):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(mutate(lines[:40])) + "\n", encoding="utf-8")
    with pytest.raises(LogFormatError) as err:
        read_attitude_log(path)
    assert message in str(err.value) and str(err.value).startswith(str(path))
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", "--log", str(path), "--out", str(out)])
    assert res.exit_code == 2 and res.output.count("\n") == 1, res.output
    assert res.output.startswith(f"error: --log {path}") and not out.exists()


def test_options_that_do_not_apply_to_an_attitude_log(short, tmp_path):
    res = CliRunner().invoke(slam.cli.main, ["run", "--log", str(short), "--mode", "local",
                                             "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "has no filter modes" in res.output
    res = CliRunner().invoke(slam.cli.main, ["run", "--log", str(short), "--filters", "hinf",
                                             "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "unknown filter hinf" in res.output
