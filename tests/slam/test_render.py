"""The generic report writer (:mod:`slam.render`): strict summary.json, self-contained HTML,
atomic writes, NaN as null; exercised with a small planar campaign's report.
"""

from __future__ import annotations

import base64
import json
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from slam.kinds.planar import report
from slam.render import output, tables
from slam.results import CampaignResult
from tests.slam.small_campaign import FIGURES, ROWS, plain, strict_loads


@pytest.fixture
def result(planar_result) -> CampaignResult:
    """The session's small planar campaign (``tests/slam/conftest.py``)."""
    return planar_result


@pytest.fixture
def written(planar_written) -> tuple[Path, list[Path]]:
    """Its report folder and the files written."""
    return planar_written


def test_summary_is_strict_json_equal_to_result(result, written):
    out, _ = written
    loaded = strict_loads((out / "summary.json").read_text(encoding="utf-8"))
    assert loaded == plain(result.summary)
    assert list(loaded) == list(result.summary)  # key order kept


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
