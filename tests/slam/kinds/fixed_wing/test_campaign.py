"""A small fixed-wing campaign end to end through ``slam run``: summary, Table 1 beside the
paper's, the turn table, the terminal table and the figures."""

from __future__ import annotations

import json
import math

from click.testing import CliRunner

import slam.cli
from benchmarks.fuzz.tomlio import dumps
from slam.kinds.fixed_wing.report import REPORT
from tests.slam.kinds.fixed_wing.worlds import SHORT_FLIGHT, fw_doc

FILTERS = ["ea-ckf", "ins-ckf", "ins-ukf"]


def test_a_small_campaign_through_the_command_line(tmp_path) -> None:
    doc = fw_doc(**{**SHORT_FLIGHT, "duration_s": 20.0}, runs=2, **{"filters.names": FILTERS})
    path = tmp_path / "short-fw.toml"
    path.write_text(dumps(doc), encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--workers", "1", "--out",
                                             str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert s["kind"] == "fixed-wing" and s["runs"] == 2 and list(s["filters"]) == FILTERS
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, (name, e.get("failures"))
        assert set(e["table1"]) >= {"heading_deg"} and 0.0 < e["anees"]
    assert set(s["filters"]["ins-ckf"]["table1"]) == {
        "longitude_m", "latitude_m", "east_velocity_mps", "north_velocity_mps", "heading_deg"}
    acc = s["accelerometer_angle_error_deg"]
    assert acc["turns"]["roll"]["max"] > 15.0 and acc["accelerating"]["pitch"]["max"] > 1.0
    bound = math.degrees(math.atan(0.05 / 9.80665))  # steady: |a| below accel_mps2 = 0.05
    assert acc["steady"]["roll"]["max"] < bound and acc["steady"]["pitch"]["max"] < bound
    md = REPORT.markdown(s)
    assert "| CKF (paper) | 4.30 | 4.00 | 2.00 | 0.80 | 0.90 |" in md
    assert "ins-ckf (ours)" in md and "gravity rule, error-free (RMS)" in md
    assert "| roll accel. (°) |" in md
    text = REPORT.text_table(s)
    assert max(len(line) for line in text.splitlines()[:14]) <= 100
    assert "UKF (paper)" in res.output
    for fig in ("attitude_errors.png", "nav_errors.png", "nees.png"):
        assert (out / fig).stat().st_size > 10_000
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "Table 1: paper vs ours" in report
    # the decision first: the headline, the rankings (position: the INS filters only), the
    # settings, the paper's orderings tested; the smoother's cost in its own column
    order = ["## Decision", "## Ranking: INS position", "## Ranking: attitude",
             "## Ranking: heading", "## Filter settings", "## The paper's ordering, tested",
             "## Table 1"]
    assert [report.index(t) for t in order] == sorted(report.index(t) for t in order)
    assert set(s["ranking"]["position"]["rows"]) == {"ins-ckf", "ins-ukf"}
    assert set(s["ranking"]["heading"]["rows"]) == set(FILTERS)
    assert s["ranking"]["position"]["reference"]["name"] == "gtsam"
    assert s["headline"].startswith("INS position (3-D): ins-")
    assert s["filters"]["ins-ukf"]["settings"] == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert s["filters"]["ea-ckf"]["settings_text"] == ""
    assert [(o["metric"], o["better"], o["worse"]) for o in s["paper_ordering"]] == [
        ("position", "ins-ckf", "ins-ukf"), ("heading", "ins-ckf", "ins-ukf")]
    assert "| ins-ukf | α = 1, β = 0, κ = 3 − n |" in report
    assert "| ms/cycle | s/run |" in report and "| per run only |" in report
    assert "rank" in res.output and "ins-ckf beats ins-ukf" in res.output
    assert max(len(line) for line in text.splitlines()) <= 100
