"""A small alignment campaign end to end through ``slam run``: summary, report sections,
the terminal table (<= 100 columns) and the figures; and the settling-time rule."""

from __future__ import annotations

import json
from importlib.resources import files
from pathlib import Path

import numpy as np
from click.testing import CliRunner

import slam.cli
from slam.kinds.alignment.report import REPORT
from slam.kinds.alignment.scoring import settle_time

FILTERS = {"ukf", "uthinf", "srckf", "srchinf", "ekf"}


def test_settle_time() -> None:
    t = np.arange(6.0)
    assert settle_time(np.array([9.0, 3.0, 1.3, 1.1, 1.0, 1.0]), t, 1.2) == 3.0
    assert settle_time(np.array([1.0, 1.0, 1.0]), t[:3], 1.2) == 0.0
    assert settle_time(np.array([np.nan, 5.0, np.nan, 1.0]), t[:4], 1.2) == 3.0
    assert settle_time(np.full(3, np.nan), t[:3], 1.2) is None


def test_a_small_campaign_through_the_command_line(tmp_path: Path) -> None:
    text = (files("worlds") / "alignment.toml").read_text(encoding="utf-8")
    for old, new in (("duration_s = 200.0", "duration_s = 3.0"), ("runs = 50", "runs = 2"),
                     ("settled_from_s = 50.0", "settled_from_s = 1.0"),
                     ("gammas = [0.3, 0.5, 1.0, 2.0, 5.0]", "gammas = [0.3, 5.0]")):
        assert text.count(old) == 1
        text = text.replace(old, new)
    path = tmp_path / "short-alignment.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--workers", "1",
                                             "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert s["kind"] == "alignment" and s["runs"] == 2 and set(s["filters"]) == FILTERS
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, (name, e.get("failures"))
        assert set(e["final_rms_arcmin"]) == {"east", "north", "azimuth"}
    for e in s["filters"].values():
        assert e["anees"] > 0 and len(e["anees_bounds_95"]) == 2 and e["anees_state"] > 0
        assert e["anees_level"] > 0 and len(e["anees_level_bounds_95"]) == 2
    assert s["limits"]["azimuth_observable"] is False
    assert 0.4 < s["limits"]["tilt_limit_arcmin"] < 0.6
    report = (out / "report.md").read_text(encoding="utf-8")
    for title in ("## Results", "## Paper vs ours", "## Theoretical limits", "## H∞ γ sweep",
                  "## The paper's ordering, tested"):
        assert title in report
    # the decision first: the headline, then a ranking per headline metric, the settings
    assert report.index("## Decision") < report.index("## Ranking: level") < report.index(
        "## Ranking: azimuth") < report.index("## Filter settings") < report.index("## Results")
    assert set(s["ranking"]) == {"level", "azimuth"} and s["headline"].startswith("Level")
    assert set(s["ranking"]["level"]["rows"]) == FILTERS
    assert s["ranking"]["level"]["reference"]["name"] == "gtsam"
    assert s["filters"]["uthinf"]["settings"] == {"alpha": 1e-3, "beta": 2.0, "kappa": 0.0,
                                                  "gamma": 5.0, "on_failure": "kalman"}
    assert "| uthinf | α = 0.001, β = 2, κ = 0, γ = 5, on failure: kalman |" in report
    assert s["paper_ordering"][0]["better"] == "uthinf" and s["paper_ordering"][0]["runs"] == 2
    assert [r["gamma"] for r in s["gamma_sweep"]["rows"]] == [0.3, 5.0, 0.3, 5.0]
    # the smoother's cost per run, in its own column
    assert "| gtsam |" in report and "per run only" in report and "| s/run |" in report
    assert "rank" in res.output and s["headline"].split(";")[0][:60] in " ".join(
        res.output.split())
    assert "not observable" in res.output and "uthinf" in res.output
    table = res.output.split("\n\n")[0].splitlines()
    assert table[0].split()[:4] == ["estimator", "E′", "N′", "az′"] and "in band" in table[0]
    assert max(map(len, table)) <= 100
    assert all(row.split()[-1].count("/") == 1 for row in table[2:])  # diverged runs last
    assert max(len(line) for line in REPORT.text_table(s).splitlines()) <= 100
    assert "| uthinf | settles within 50 s |" in REPORT.markdown(s)
    for f in REPORT.figures():
        assert (out / f).stat().st_size > 10_000, f
