"""The planar report (:mod:`slam.kinds.planar.report`): its files, tables, rows, terminal
table and TUM trajectories.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from slam.kinds.planar import report
from slam.render import tables
from slam.results import CampaignResult
from tests.slam.small_campaign import FIGURES, ROWS


@pytest.fixture
def result(planar_result) -> CampaignResult:
    """The session's small planar campaign (``tests/slam/conftest.py``)."""
    return planar_result


@pytest.fixture
def written(planar_written) -> tuple[Path, list[Path]]:
    """Its report folder and the files written."""
    return planar_written


def _table_names(markdown: str) -> list[str]:
    lines = [ln for ln in markdown.splitlines() if ln.startswith("| ")]
    assert lines[0].startswith("| estimator |")
    return [ln.split("|")[1].strip() for ln in lines[1:]]


def test_all_files_written(result, written):
    out, paths = written
    expected = {"summary.json", "report.md", "report.html", *FIGURES, "truth.tum",
                *(f"{n}.tum" for n in ROWS), *(f"{n}.cov.txt" for n in ROWS), ".slam-output"}
    assert {p.name for p in paths} == expected
    assert {p.name for p in out.iterdir()} == expected
    assert all(p.parent == out and p.stat().st_size > 0 for p in paths)
    for name in FIGURES:
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) < 300_000
    assert [p.name for p in out.parent.iterdir()] == ["small"]  # no temp dirs left


def test_markdown_tables(result, written):
    out, _ = written
    md = (out / "report.md").read_text(encoding="utf-8")
    assert _table_names(report.results_table(result.summary)) == ROWS
    assert report.results_table(result.summary) in md
    assert "small" in md and "Test world: 30 m square loop" in md
    assert "2 Monte Carlo runs, seed 0" in md
    assert "test paper, Fig. 1" in md
    # paper vs ours: srckf with our range next to the paper's, srukf not run
    paper_row = next(ln for ln in md.splitlines() if ln.startswith("| srckf |")
                     and "[-0.50, +0.60]" in ln)
    x_lo, x_hi = result.summary["filters"]["srckf"]["pos_err_range_m"]["x"]
    assert f"[{x_lo:+.2f}, {x_hi:+.2f}]" in paper_row
    assert "| srukf (not run) |" in md
    for name in FIGURES:
        assert f"]({name})" in md


def test_results_row_values(result):
    rows = {r[0]: r for r in report.result_rows(result.summary)}
    ekf = result.summary["filters"]["ekf"]
    assert rows["ekf"][1] == f"{ekf['pos_rmse_m']:.3f}"
    header = list(report.RESULTS.header)
    col = {h: header.index(h) for h in header}
    assert rows["ekf"][col["time/epoch (µs)"]] == f"{ekf['time_per_step_s'] * 1e6:.1f}"
    assert rows["ekf"][col["diverged runs"]] == "0/2"
    assert rows["ekf"][col["in band"]] == f"{100 * ekf['anees_steps_inside_95']:.0f} %"
    assert rows["ekf"][col["verdict"]] == tables.verdict(ekf)
    assert rows["odometry"][col["landmark RMSE (m)"]] == tables.MISSING  # no landmarks
    assert rows["gtsam"][col["NIS/dof"]] == tables.MISSING  # no NIS


def test_text_table_is_aligned(result):
    """Two header lines, a rule, one row per estimator, then the notes; ≤ 100 columns."""
    lines = report.REPORT.text_table(result.summary).splitlines()
    assert lines[2].startswith("---------")
    assert [ln.split()[0] for ln in lines[3:3 + len(ROWS)]] == ROWS
    assert lines[3 + len(ROWS)].startswith("ANEES 95 % band [")
    assert max(len(ln) for ln in lines) <= 100
    # right-aligned numeric columns: every row's pos RMSE ends at the same column
    header_end = lines[0].index("pos RMSE") + len("pos RMSE")
    for ln in lines[3:3 + len(ROWS)]:
        assert re.fullmatch(r"\d+\.\d{3}", ln[header_end - 5:header_end])


def test_tum_files(result, written):
    out, _ = written
    first = result.outcomes[0]
    k1 = len(first.times)
    truth = np.loadtxt(out / "truth.tum")
    assert truth.shape == (k1, 8)
    x, y, phi = first.truth[0]
    np.testing.assert_allclose(
        truth[0], [first.times[0], x, y, 0, 0, 0, math.sin(phi / 2), math.cos(phi / 2)],
        atol=1e-6)
    assert (out / "srckf.tum").read_text().startswith("# small: srckf, run 0 of 2 (seed 0)")
    for name in ROWS:
        rows = np.loadtxt(out / f"{name}.tum")
        assert rows.shape == (k1, 8)
        poses = first.tracks[name].poses
        np.testing.assert_allclose(rows[:, 0], first.times, atol=1e-6)
        np.testing.assert_allclose(rows[:, 1:3], poses[:, :2], atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(rows[:, 4:], axis=1), 1.0, atol=1e-6)
        yaw = 2 * np.arctan2(rows[:, 6], rows[:, 7])
        np.testing.assert_allclose(np.angle(np.exp(1j * (yaw - poses[:, 2]))), 0, atol=1e-6)
    assert "nan" not in (out / "ekf.tum").read_text().lower()
    # the covariance sidecar: one row per pose of the TUM file, t then the 3 x 3 pose
    # covariance of [x, y, heading]
    cov = np.loadtxt(out / "srckf.cov.txt")
    assert cov.shape == (k1, 10)
    np.testing.assert_allclose(cov[:, 0], first.times, atol=1e-6)
    np.testing.assert_allclose(cov[:, 1:].reshape(-1, 3, 3), first.tracks["srckf"].pose_cov,
                               rtol=1e-8, atol=1e-15)


def test_tum_drops_non_finite_rows():
    text = report.tum_text(np.array([0.0, 1.0, 2.0]),
                           np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [2.0, 3.0, np.pi]]))
    rows = np.array([[float(v) for v in ln.split()] for ln in text.splitlines()])
    np.testing.assert_allclose(rows, [[0, 0, 0, 0, 0, 0, 0, 1], [2, 2, 3, 0, 0, 0, 1, 0]],
                               atol=1e-9)
