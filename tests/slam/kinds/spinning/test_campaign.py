"""A small ``spinning`` campaign end to end through ``slam run`` (the kind registered as a
plug-in), the sweep's bookkeeping, and a bad world exiting 2."""

from __future__ import annotations

import json
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from slam.kinds.spinning import sweep as sw
from tests.slam.kinds.spinning.helpers import tiny_world

FILTERS = {"srckf", "srchinf", "ekf"}  # few rows: the figures are most of the test's time


def _tiny_file(tmp_path: Path, **replace: str) -> Path:
    text = (files("worlds") / "spinning.toml").read_text(encoding="utf-8")
    for old, new in {"sample_interval_s = 0.1": "sample_interval_s = 1.0",
                     "factors = [1.0, 2.0, 5.0, 10.0]": "factors = [1.0, 5.0]",
                     "gammas_rad = [0.5, 1.0, 2.0, inf]": "gammas_rad = [2.0, inf]",
                     'scales = ["both", "gyro", "magnetometer"]': 'scales = ["both", "gyro"]',
                     "runs_per_cell = 4": "runs_per_cell = 1",
                     'filters = ["ukf", "srckf", "ekf", "srchinf"]':
                     'filters = ["srckf", "srchinf"]',
                     'names = ["ukf", "ckf", "srckf", "svdckf", "srchinf", "uthinf", "ekf"]':
                     'names = ["srckf", "srchinf", "ekf"]', **replace}.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "tiny-spin.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_small_campaign_through_the_cli(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(_tiny_file(tmp_path)), "--runs", "2",
                                             "--workers", "1", "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "srchinf" in res.output and "gtsam " in res.output and "in band" in res.output
    assert max(map(len, res.output.splitlines()[:-1])) <= 100  # tables, headline (not the path)
    assert "yaw: paired ranking over 2 runs" in res.output and "ΔMSE vs best" in res.output
    assert "settings of srchinf: γ = 0.5" in res.output and "s per run" in res.output
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert s["kind"] == "spinning" and s["runs"] == 2 and set(s["filters"]) == FILTERS
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, (name, e.get("failures"))
        assert 0.0 < e["pitch_rmse_deg"] < 1.0 and 0.0 < e["yaw_rmse_deg"] < 5.0, name
        assert e["roll_rmse_outside_deg"] < e["roll_rmse_blind_deg"], name
        lo, hi = e["anees_bounds_95"]
        assert lo < 1.0 < hi and 0.0 < e["anees"] < 10.0 and 0.0 <= e["anees_steps_above_95"]
    assert s["filters"]["srchinf"]["hinf_updates"] == 2 * 88
    f = s["flight"]
    assert math.isclose(f["flight_time_s"], 87.5, rel_tol=0.02) and f["drag_calibrated"]
    assert 60.0 < s["blind_area"]["from_s"] < s["blind_area"]["to_s"] < 85.0
    assert s["blind_area"]["detector_agreement"] > 0.9
    assert all(0.0 < v < 10.0 for v in s["prior_draws_mean_sq"].values())
    sweep = s["sweep"]
    assert sweep["logs_done"] == 2 and sweep["rows"] == ["srckf", "srchinf γ=2", "srchinf γ=∞"]
    assert sweep["scales"] == ["both", "gyro"]
    cells = {(c["scale"], c["factor"], c["row"]): c for c in sweep["cells"]}
    for factor in (1.0, 5.0):  # the first two logs: the "both" cells
        assert cells["both", factor, "srchinf γ=∞"]["rmse_pitch_deg"] == cells[
            "both", factor, "srckf"]["rmse_pitch_deg"]
        assert cells["gyro", factor, "srckf"]["logs"] == 0
    assert (cells["both", 5.0, "srckf"]["rmse_pitch_deg"]
            > cells["both", 1.0, "srckf"]["rmse_pitch_deg"])
    rank = s["ranking"]
    assert set(rank) == {"pitch", "yaw", "roll_blind"} and rank["yaw"]["runs"] == 2
    assert set(rank["pitch"]["rows"]) == FILTERS and "gtsam" not in rank["pitch"]["rows"]
    assert rank["pitch"]["reference"]["name"] == "gtsam" and s["headline"].startswith("Pitch:")
    assert s["filters"]["srchinf"]["settings"] == {"gamma": 0.5, "on_failure": "kalman"}
    assert set(s["paper_ranking"]["yaw"]["rows"]) == {"srckf", "srchinf"}  # not the EKF
    report = (out / "report.md").read_text(encoding="utf-8")
    titles = [line for line in report.splitlines() if line.startswith("## ")]
    assert titles[:3] == ["## Decision", "## Results", "## Ranking: pitch: paired ranking "
                          "over 2 runs (significant: ΔMSE > 2 s.e.; separated: > 3 s.e.)"]
    for title in ("## Filter settings", "## Paper vs ours", "## H∞ existence check",
                  "## Noise-mismatch sweep: gyro and magnetometer (gaussian)",
                  "## Noise-mismatch sweep: gyro only (gaussian)", "## How to read this"):
        assert title in report, title


def test_the_kinds_own_figures(tmp_path: Path) -> None:
    """The figures drawn here (the shared ones are the renderer's): the errors and the
    differences with the blind area, roll, the sweep, the flight; and the note on curves that
    coincide."""
    from slam.campaign import run_campaign
    from slam.kinds.spinning.figures import (
        figures,
        plot_differences,
        plot_errors,
        plot_flight,
        plot_roll,
        plot_sweep,
    )

    assert list(figures()) == ["errors.png", "roll.png", "rmse_sigma.png", "nees.png",
                               "differences.png", "sweep.png", "flight.png"]
    w = tiny_world(**{"runs": 2, "filters.names": ["srckf", "srchinf", "ekf"]})
    result = run_campaign(w, workers=1)
    for draw in (plot_errors, plot_differences, plot_roll, plot_sweep, plot_flight):
        path = tmp_path / f"{draw.__name__}.png"
        draw(result, path)
        assert path.stat().st_size > 10_000, path


def test_a_bad_world_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    bad = _tiny_file(tmp_path, **{"rate_rev_s = 15.0": "rate_rev_s = -15.0"})
    res = CliRunner().invoke(slam.cli.main, ["run", str(bad), "--out", str(out)])
    assert res.exit_code == 2 and "spin" in res.output and "rate_rev_s" in res.output
    assert not out.exists()


def test_sweep_cells_cycle_before_replicating() -> None:
    spec = tiny_world(**{"sweep.factors": [1.0, 2.0, 5.0],
                         "sweep.distributions": ["gaussian", "student-t"],
                         "sweep.runs_per_cell": 2}).sweep
    cells = [sw.cell_of(spec, t) for t in range(spec.tasks)]
    assert spec.scales == ("both",) and spec.tasks == 12 and len(set(cells)) == 12
    assert {c[1:3] for c in cells[:6]} == {(d, f) for d in ("gaussian", "student-t")
                                           for f in (1.0, 2.0, 5.0)}
    assert [c[3] for c in cells] == [0] * 6 + [1] * 6
    three = tiny_world(**{"sweep.scales": ["both", "gyro", "magnetometer"]}).sweep
    assert [sw.cell_of(three, t)[0] for t in range(3)] == ["both", "gyro", "magnetometer"]


def test_largest_difference_names_the_pair() -> None:
    from slam.kinds.spinning.figures import largest_difference

    curves = {"a": np.array([0.0, 1.0, np.nan]), "b": np.array([0.0, 1.5, 9.0]),
              "c": np.array([0.2, 1.0, np.nan])}
    assert largest_difference(curves) == (0.5, "a", "b")
    assert largest_difference({"a": curves["a"]}) is None
    from slam.kinds.spinning.figures import coinciding

    near = {"a": np.array([1.0, 2.0, 3.0]), "b": np.array([1.001, 2.001, 3.001]),
            "c": np.array([2.0, 3.0, 4.0])}
    groups = coinciding(near)
    assert len(groups) == 1 and groups[0][0] == ["a", "b"]
    assert groups[0][1] == pytest.approx(0.001)


def _block(order: list[str], verdicts: dict[str, str], z: float = 4.0) -> dict:
    rows = {n: {"rank": i + 1, "verdict": verdicts.get(n, "best" if i == 0 else "separated"),
                "z": None if i == 0 else z} for i, n in enumerate(order)}
    return {"order": order, "rows": rows}


def test_the_papers_claims_are_judged_from_the_paired_ranking() -> None:
    from slam.kinds.spinning.report import claim_verdict

    block = _block(["srchinf", "srckf", "ukf"], {})
    assert claim_verdict(block, "srchinf", "best").startswith("reproduced")
    assert claim_verdict(block, "ukf", "worst").startswith("reproduced")
    assert claim_verdict(block, "srckf", "worst").startswith("not reproduced")
    assert claim_verdict(block, "srchinf", "worst").startswith("contradicted")
    assert claim_verdict(block, "ckf", "best").startswith("not tested")
    close = _block(["srckf", "srchinf", "ukf"], {"srchinf": "not significant"}, z=1.0)
    assert claim_verdict(close, "srchinf", "best").startswith("not decided")
    assert claim_verdict(close, "srckf", "best").startswith("not decided")
    assert claim_verdict(close, "ukf", "best").startswith("contradicted")
    assert claim_verdict(close, "srckf", "worst").startswith("contradicted")  # ukf is worse
    tie = _block(["srckf", "srchinf"], {"srchinf": "equal"}, z=0.1)
    assert claim_verdict(tie, "srckf", "worst").startswith("not reproduced")
    assert claim_verdict(tie, "srchinf", "worst").startswith("not decided")
