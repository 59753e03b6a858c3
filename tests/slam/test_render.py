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

from slam.kinds.planar import figures as planar_figures
from slam.kinds.planar import report
from slam.render import output, tables
from slam.render.provenance import provenance_rows
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
    """Figures are embedded; the only links are relative ones to the folder's own files."""
    out, _ = written
    text = (out / "report.html").read_text(encoding="utf-8")
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(uris) == len(FIGURES)
    assert all(base64.b64decode(u).startswith(b"\x89PNG") for u in uris)
    assert not re.search(r"""src\s*=\s*(?!["']?data:)""", text, re.I)
    links = re.findall(r"""href\s*=\s*["']?([^"' >]*)""", text, re.I)
    assert {"summary.json", "report.md", "srckf.tum", "truth.tum"} <= set(links)
    assert all("/" not in h and ":" not in h and (out / h).is_file() for h in links), links
    assert not re.search(r"<(?:link|script)\b|@import|url\(", text, re.I)
    # results header + rows, the segments (header + filters), a ranking table (header +
    # filters) per headline metric, paper header + 2 rows, provenance header + its items
    summary = strict_loads((out / "summary.json").read_text())
    prov = provenance_rows(summary["provenance"])
    ranks = sum(1 + len(b["rows"]) for b in summary["ranking"].values())
    assert ranks == 2 * (1 + 2)  # position and landmarks, ekf and srckf
    segments = 1 + len(summary["segments"]["estimators"])
    assert segments == 1 + 2
    assert text.count("<tr>") == 1 + len(ROWS) + segments + ranks + 1 + 2 + 1 + len(prov)
    assert "<td>odometry</td>" in text and "<td>gtsam</td>" in text


def test_provenance_block_only_when_the_summary_has_one(result, written):
    out, _ = written
    md = (out / "report.md").read_text(encoding="utf-8")
    prov = result.summary["provenance"]
    assert md.count("## Provenance") == 1 and f"| command line | {prov['command']} |" in md
    assert f"commit {prov['git_commit'][:12]}" in md if prov["git_commit"] else True
    assert "Provenance: navfilters" in md.split("## ")[0]  # the line under the title
    bare = replace(result, summary={k: v for k, v in result.summary.items()
                                    if k != "provenance"})
    from slam.render.document import report_html, report_markdown

    assert "Provenance" not in report_markdown(bare, report.REPORT, [])
    assert "Provenance" not in report_html(bare, report.REPORT, {})


def _sentinel(out: Path) -> dict[str, str]:
    """An earlier output of the tool (it holds the marker)."""
    out.mkdir(parents=True)
    (out / "summary.json").write_text('{"old": true}\n')
    (out / output.MARKER).write_text("{}\n")
    return {"summary.json": '{"old": true}\n', output.MARKER: "{}\n"}


def _contents(out: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in out.iterdir()}


def test_failure_mid_way_leaves_old_output(result, tmp_path, monkeypatch):
    out = tmp_path / "run"
    old = _sentinel(out)
    drawn = []

    def boom(res, path):
        drawn.append(path)
        raise RuntimeError("plot failed")

    monkeypatch.setattr(planar_figures, "plot_errors_xy", boom)
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


def _entry(anees, inside=None, above=None):
    e = {"anees": anees, "anees_bounds_95": [0.79, 1.24]}
    if inside is not None:
        e["anees_steps_inside_95"] = inside
    if above is not None:
        e["anees_steps_above_95"] = above
    return e


def test_verdict_calls_consistent_only_when_both_checks_hold():
    v = tables.verdict
    assert v(_entry(1.10, 0.96, 0.02)) == "consistent"
    # the issue's case: ANEES inside its band, 77.6 % of epochs inside, most misses above
    assert v(_entry(1.10, 0.776, 0.20)) == "optimistic"
    assert v(_entry(0.95, 0.70, 0.02)) == "pessimistic"
    assert v(_entry(1.00, 0.70, 0.15)) == "mixed"
    assert v(_entry(1.30, 0.99)) == "optimistic" and v(_entry(0.70, 0.99)) == "pessimistic"
    assert v(_entry(1.10)) == "" and v({}) == "" and v(_entry(float("nan"), 0.99)) == ""
    assert "90 %" in tables.consistency_rule()


def test_plain_table_takes_two_line_headers():
    text = tables.plain_table(["name", "pos RMSE\n(m)", "x"], [["ekf", "1.055", "3"]])
    lines = text.splitlines()
    assert lines[0] == "      pos RMSE" and lines[1] == "name       (m)  x"
    assert lines[3] == "ekf      1.055  3"
    md = tables.markdown_table(["a\nb", "|e|"], [["1", "2"]])
    assert md.startswith("| a b | \\|e\\| |")


def test_terminal_text_prints_failure_reasons_and_fits():
    summary = {"filters": {
        "ekf": {"runs_scored": 48, "diverged_runs": 2,
                "failures": ["NotPositiveDefiniteError: factor lost rank at epoch 12",
                             "Divergence: vehicle error above 50.0 m at step 800 " * 3]},
        "srckf": {"runs_scored": 50, "diverged_runs": 0}},
        "reference": {"gtsam": {"diverged": True, "failure": "IndeterminantLinearSystem"}}}
    text = tables.terminal_text(tables.Table((tables.ESTIMATOR, tables.DIVERGED_SHORT)),
                                summary, [tables.band_note(summary)])
    assert "ekf diverged on 2/50 runs: NotPositiveDefiniteError" in text
    assert "gtsam diverged: IndeterminantLinearSystem" in text
    assert "srckf diverged" not in text
    assert max(len(line) for line in text.splitlines()) <= tables.TERMINAL_WIDTH
