"""A small ship campaign end to end through ``slam run`` (the kind registered by
``tests.slam.kinds.ship.worlds``): summary, report sections, the terminal table and the
figures; and the convergence-time and paired-comparison helpers."""

from __future__ import annotations

import json
import math
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np
from click.testing import CliRunner, Result

import slam.cli
from slam.kinds.ship.report import REPORT
from slam.kinds.ship.scoring import settle_times
from tests.slam.kinds.ship import worlds  # noqa: F401  (registers the kind)

FILTERS = {"hommukf", "ukf", "cdkf", "srckf", "ekf"}


def test_settle_times() -> None:
    t = np.arange(5.0)
    ok = np.array([[False, True, False, True, True], [True] * 5, [True, True, True, True, False]])
    got = settle_times(ok, t)
    assert got[0] == 3.0 and got[1] == 0.0 and math.isnan(got[2])


def _short_world(tmp_path: Path) -> Path:
    text = (files("worlds") / "ship.toml").read_text(encoding="utf-8")
    for old, new in (("duration_s = 300.0", "duration_s = 8.0"), ("runs = 50", "runs = 2"),
                     ("steady_state_from_s = 100.0", "steady_state_from_s = 4.0")):
        assert text.count(old) == 1
        text = text.replace(old, new)
    path = tmp_path / "short-ship.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _run(tmp_path: Path, *options: str) -> tuple[Result, Path, dict[str, Any]]:
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(_short_world(tmp_path)), "--workers",
                                             "1", "--out", str(out), *options])
    assert res.exit_code == 0, res.output
    return res, out, json.loads((out / "summary.json").read_text(encoding="utf-8"))


def test_a_small_campaign_through_the_command_line(tmp_path) -> None:
    res, out, s = _run(tmp_path, "--no-plots")
    assert s["kind"] == "ship" and s["runs"] == 2 and set(s["filters"]) == FILTERS
    assert set(s["variants"]) == {"ukf:additive", "ukf:manifold"}
    for name, e in [*s["filters"].items(), *s["variants"].items(),
                    ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, (name, e.get("failures"))
        assert set(e["att_rms_arcmin"]) == {"roll", "pitch", "yaw"}
        assert 0.0 < e["anees"] and len(e["anees_bounds_95"]) == 2
    assert {c["a"] for c in s["comparisons"]} >= {"hommukf", "ukf:additive", "ukf"}
    report = (out / "report.md").read_text(encoding="utf-8")
    for title in ("## Results", "## Paper vs ours", "## Effects", "## Paired comparisons"):
        assert title in report
    assert "ukf:additive" in res.output and "yaw ss′" in res.output
    assert max(map(len, res.output.split("\n\n")[0].splitlines())) <= 100  # the table
    assert "| (a) | ukf:additive |" in REPORT.markdown(s)


def test_the_report_and_the_terminal_decide(tmp_path) -> None:
    """The headline and the rank tables lead the report and close the terminal output;
    every filter's settings are in summary.json and beside its row; the paper's ordering
    is tested pair by pair."""
    res, out, s = _run(tmp_path, "--no-plots")
    ranking = s["ranking"]
    assert set(ranking) == {"attitude_steady", "attitude"}
    for block in ranking.values():
        assert set(block["rows"]) == FILTERS and block["runs"] == 2
        assert [block["rows"][n]["rank"] for n in block["order"]] == [1, 2, 3, 4, 5]
    assert s["headline"].startswith("Attitude, steady state: ")
    assert s["filters"]["ukf"]["settings"] == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert s["filters"]["ukf"]["settings_text"] == "α = 1, β = 0, κ = 3 − n"
    assert s["filters"]["hommukf"]["settings"]["moments"] == "predicted"
    assert s["filters"]["hommukf"]["homm_moments"]["predictions"] == 2 * 8  # 2 runs x 8 predictions
    po = s["paper_ordering"]
    assert po["order"] == ["hommukf", "ukf", "cdkf"] and len(po["pairs"]) == 6
    report = (out / "report.md").read_text(encoding="utf-8")
    titles = [line for line in report.splitlines() if line.startswith("## ")]
    assert titles[0] == "## Decision" and titles[1].startswith("## Ranking: attitude, steady")
    assert "## The paper's ordering: ranks, paired ΔMSE and consistency" in titles
    assert titles.index("## Filter settings") < titles.index("## Results")
    assert "| unscented (α = 1, β = 0, κ = 3 − n) |" in report  # beside the effects row
    assert "rank" in res.output and "ΔMSE vs best (± s.e.)" in res.output
    assert s["headline"].split(".")[0][:60] in res.output.replace("\n", " ")
    text = res.output.split("\n\n" + "2 runs x")[0]  # the CLI's closing line holds the path
    assert max(map(len, text.splitlines())) <= 100


def test_the_report_figures_are_drawn(tmp_path, monkeypatch) -> None:
    """Every figure is written; the attitude panels' y range leaves out the transient
    before 30 s (here the 8 s run's last epoch alone sets it), and a fourth column draws
    the yaw transient itself (the first 30 s, here the whole 8 s) on its own scale."""
    import slam.kinds.ship.figures as figures

    panels, grids, real = [], [], figures.error_grid

    def spy(result, path, grid, panel, colours):
        panels.extend((panel(n, c), result) for n in figures._names(result) for c in range(3))
        transient = [panel(n, 3) for n in figures._names(result)]
        grids.append((grid, transient, [panel(n, 2) for n in figures._names(result)]))
        return real(result, path, grid, panel, colours)

    monkeypatch.setattr(figures, "error_grid", spy)
    _, out, s = _run(tmp_path, "--filters", "hommukf,ekf")
    assert set(s["filters"]) == {"hommukf", "ekf"} and not s["variants"]
    for f in REPORT.figures():
        assert (out / f).stat().st_size > 10_000, f
    assert len(panels) == 9  # hommukf, ekf and the smoother, three axes each
    (grid, transient, yaw), = grids
    assert len(grid.axes) == 4 and grid.windows == (None, None, None, 8.0)
    for t, y in zip(transient, yaw):
        assert t.settle == 0 and (t.env is None or np.array_equal(t.env, y.env, equal_nan=True))
    for p, result in panels:
        times = result.outcomes[0].times
        assert p.settle == len(times) - 1 and times[p.settle] == times[-1]
        if p.env is not None:
            assert p.extent()[0] == np.nanmax(np.abs(np.asarray(p.env)[:, -1:]))
