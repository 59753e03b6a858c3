"""``slam run --log FILE`` end to end: a bad log exits 2 naming file and line; a good one
writes a strict summary and the report.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from slam.cli import main
from slam.kinds.recorded.log import (
    format_odometry_log,
)
from tests.slam.kinds.recorded.synthetic import synthetic_log

GOOD = "ODOMETRY 0 1 1 0 0 1e-4 0 0 4e-6 0 4e-6\n"


def test_cli_bad_log_exits_2_with_file_line_and_writes_nothing(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text(GOOD + "LANDMARK 1 7 3 x 0.4 0 0.4\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(bad), "--out", str(out)])
    assert res.exit_code == 2
    assert f"{bad}:2:" in res.output and "not a number" in res.output
    assert not out.exists()
    res = CliRunner().invoke(main, ["run", "--log", str(bad), "--runs", "3"])
    assert res.exit_code == 2 and "--runs does not apply to --log" in res.output



def test_cli_runs_a_log_and_writes_strict_summary(tmp_path):
    log = synthetic_log(np.random.default_rng(2), n_poses=30, n_landmarks=4)
    path = tmp_path / "small.txt"
    path.write_text(format_odometry_log(log))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(path), "--out", str(out),
                                    "--filters", "ekf,srckf", "--no-plots"])
    assert res.exit_code == 0, res.output
    text = (out / "summary.json").read_text()
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict {c}"))
    assert data["mode"] == "local" and set(data["filters"]) == {"ekf", "srckf"}
    assert data["poses"] == 30 and "objective" in data["reference"]["gtsam"]
    assert "landmark_dist_to_ref_max_m" in data["filters"]["srckf"]
    assert "srckf" in res.output and "gtsam" in res.output
    # the figures are checked with every kind's in tests/slam/test_reports.py
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [".slam-output", "report.html", "report.md", "summary.json", "ekf.tum", "srckf.tum",
         "gtsam.tum", "odometry.tum", "ekf.cov.txt", "srckf.cov.txt"])
    assert (out / "srckf.tum").read_text().startswith("# small.txt: srckf; time column = pose")
    # the sidecar: one line per pose of the TUM file, the filter's own pose covariance
    from slam.kinds.recorded.models import run_recorded

    tum = np.loadtxt(out / "srckf.tum")
    side = np.loadtxt(out / "srckf.cov.txt")
    np.testing.assert_array_equal(side[:, 0], tum[:, 0])
    own = run_recorded(log, "srckf", mode="local")
    np.testing.assert_array_equal(tum[:, 0], own.steps)
    np.testing.assert_allclose(side[:, 1:].reshape(-1, 3, 3), own.pose_cov, rtol=1e-8,
                               atol=1e-15)
    assert Path(path).exists()


def test_cli_log_figures_print_no_library_warnings(tmp_path, caplog):
    """The trajectories figure fixes its frame and its aspect together: matplotlib logs
    nothing ("Ignoring fixed y limits ..." once reached the terminal)."""
    log = synthetic_log(np.random.default_rng(2), n_poses=30, n_landmarks=4)
    path = tmp_path / "small.txt"
    path.write_text(format_odometry_log(log))
    out = tmp_path / "out"
    with caplog.at_level("INFO"):
        res = CliRunner().invoke(main, ["run", "--log", str(path), "--out", str(out),
                                        "--filters", "ekf"])
    assert res.exit_code == 0, res.output
    assert (out / "trajectories.png").exists()
    logged = [r.getMessage() for r in caplog.records
              if r.name.startswith("matplotlib") and r.levelname in ("WARNING", "ERROR")]
    assert logged == []
    assert "Ignoring" not in res.output
