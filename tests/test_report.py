"""Reports: strict summary.json, tables, self-contained HTML, TUM files, atomic writes."""

from __future__ import annotations

import base64
import json
import math
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from small_worlds import small_world

from slam.campaign import run_campaign
from slam.kinds.planar import report
from slam.render import output, tables
from slam.results import CampaignResult

FILTERS = ("ekf", "srckf")
ROWS = [*FILTERS, "odometry", "gtsam"]
PAPER = {
    "source": "test paper, Fig. 1",
    "filters": {"srckf": {"pos_err_range_m": {"x": [-0.5, 0.6], "y": [-0.5, 0.2]}},
                "srukf": {"pos_err_range_m": {"x": [-0.7, 1.4], "y": [-1.15, 1.6]}}},
}
FIGURES = {"map.png", "errors_xy.png", "nees.png"}


def _reject_constant(name: str):
    raise ValueError(f"non-strict JSON token {name}")


def strict_loads(text: str):
    return json.loads(text, parse_constant=_reject_constant)


def plain(obj):
    """The test's own conversion of a summary to what JSON should hold."""
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [plain(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


@pytest.fixture(scope="module")
def result() -> CampaignResult:
    world = small_world(runs=2, filters=FILTERS)
    r = run_campaign(world, runs=2, workers=1)
    return CampaignResult(r.world, {**r.summary, "paper": PAPER}, r.outcomes)


@pytest.fixture(scope="module")
def written(result, tmp_path_factory) -> tuple[Path, list[Path]]:
    out = tmp_path_factory.mktemp("report") / "small"
    return out, output.write_outputs(result, report.REPORT, out)


def _table_names(markdown: str) -> list[str]:
    lines = [ln for ln in markdown.splitlines() if ln.startswith("| ")]
    assert lines[0].startswith("| estimator |")
    return [ln.split("|")[1].strip() for ln in lines[1:]]


def test_all_files_written(result, written):
    out, paths = written
    expected = {"summary.json", "report.md", "report.html", *FIGURES, "truth.tum",
                *(f"{n}.tum" for n in ROWS)}
    assert {p.name for p in paths} == expected
    assert {p.name for p in out.iterdir()} == expected
    assert all(p.parent == out and p.stat().st_size > 0 for p in paths)
    for name in FIGURES:
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) < 300_000
    assert [p.name for p in out.parent.iterdir()] == ["small"]  # no temp dirs left


def test_summary_is_strict_json_equal_to_result(result, written):
    out, _ = written
    loaded = strict_loads((out / "summary.json").read_text(encoding="utf-8"))
    assert loaded == plain(result.summary)
    assert list(loaded) == list(result.summary)  # key order kept


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
    assert rows["ekf"][8] == f"{ekf['time_per_step_s'] * 1e6:.1f}"
    assert rows["ekf"][9] == "0/2"
    assert rows["odometry"][5] == tables.MISSING  # no landmarks
    assert rows["gtsam"][7] == tables.MISSING  # no NIS


def test_text_table_is_aligned(result):
    lines = report.REPORT.text_table(result.summary).splitlines()
    assert [ln.split()[0] for ln in lines[2:]] == ROWS
    assert len(lines) == 2 + len(ROWS)
    # right-aligned numeric columns: every row's pos RMSE ends at the same column
    header_end = lines[0].index("pos RMSE (m)") + len("pos RMSE (m)")
    for ln in lines[2:]:
        assert re.fullmatch(r"\d+\.\d{3}", ln[header_end - 5:header_end])


def test_html_is_self_contained(written):
    out, _ = written
    text = (out / "report.html").read_text(encoding="utf-8")
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(uris) == len(FIGURES)
    assert all(base64.b64decode(u).startswith(b"\x89PNG") for u in uris)
    assert not re.search(r"""(?:src|href)\s*=\s*(?!["']?data:)""", text, re.I)
    assert not re.search(r"<(?:link|script)\b|@import|url\(", text, re.I)
    assert text.count("<tr>") == 1 + len(ROWS) + 1 + 2  # header + rows, header + 2 paper
    assert "<td>odometry</td>" in text and "<td>gtsam</td>" in text


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


def test_tum_drops_non_finite_rows():
    text = report.tum_text(np.array([0.0, 1.0, 2.0]),
                           np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [2.0, 3.0, np.pi]]))
    rows = np.array([[float(v) for v in ln.split()] for ln in text.splitlines()])
    np.testing.assert_allclose(rows, [[0, 0, 0, 0, 0, 0, 0, 1], [2, 2, 3, 0, 0, 0, 1, 0]],
                               atol=1e-9)


def _sentinel(out: Path) -> dict[str, str]:
    out.mkdir(parents=True)
    (out / "summary.json").write_text('{"old": true}\n')
    return {"summary.json": '{"old": true}\n'}


def _contents(out: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in out.iterdir()}


def test_failure_mid_way_leaves_old_output(result, tmp_path, monkeypatch):
    out = tmp_path / "run"
    old = _sentinel(out)
    drawn = []

    def boom(res, path):
        drawn.append(path)
        raise RuntimeError("plot failed")

    monkeypatch.setattr(report, "plot_errors_xy", boom)
    with pytest.raises(RuntimeError, match="plot failed"):
        output.write_outputs(result, report.REPORT, out)
    assert drawn and drawn[0].parent != out  # rendering happened in a temp dir
    assert _contents(out) == old
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def test_failed_swap_restores_old_output(result, tmp_path, monkeypatch):
    out = tmp_path / "run"
    old = _sentinel(out)
    real_rename, calls = os.rename, []

    def flaky_rename(src, dst):
        calls.append((Path(src).name, Path(dst).name))
        if len(calls) == 2:  # the temp dir -> out_dir step
            raise OSError("disk gone")
        real_rename(src, dst)

    monkeypatch.setattr(os, "rename", flaky_rename)
    with pytest.raises(OSError, match="disk gone"):
        output.write_outputs(result, report.REPORT, out, plots=False)
    assert _contents(out) == old
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def test_success_replaces_old_output(result, tmp_path):
    out = tmp_path / "run"
    _sentinel(out)
    (out / "stale.png").write_text("stale")
    paths = output.write_outputs(result, report.REPORT, out, plots=False)
    names = {p.name for p in out.iterdir()}
    assert names == {p.name for p in paths}
    assert "stale.png" not in names and not FIGURES & names
    assert strict_loads((out / "summary.json").read_text())["world"] == "small"
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def test_nan_becomes_null(result, tmp_path):
    summary = json.loads(json.dumps(result.summary))
    summary["filters"]["ekf"]["anees"] = float("nan")
    summary["filters"]["ekf"]["pos_rmse_m"] = np.float64(np.inf)
    summary["filters"]["ekf"]["extra"] = np.array([1.0, np.nan])
    text = tables.summary_json(summary)
    assert "NaN" not in text and "Infinity" not in text
    loaded = strict_loads(text)
    assert loaded["filters"]["ekf"]["anees"] is None
    assert loaded["filters"]["ekf"]["pos_rmse_m"] is None
    assert loaded["filters"]["ekf"]["extra"] == [1.0, None]
    row = report.result_rows(summary)[0]
    assert row[1] == tables.MISSING and row[6] == tables.MISSING

    paths = output.write_outputs(replace(result, summary=summary), report.REPORT, tmp_path / "nan",
                                 plots=False)
    on_disk = strict_loads(paths[0].read_text())
    assert paths[0].name == "summary.json"
    assert on_disk["filters"]["ekf"]["anees"] is None


def test_unserialisable_value_is_an_error():
    with pytest.raises(TypeError, match="object"):
        tables.summary_json({"bad": object()})
