"""``benchmarks.separation``: its planar ranking is the planar kind's own (same per-run
MSEs, same paired statistics), and it tests every pair of the paper's ordering."""

from __future__ import annotations

import math

import pytest

from benchmarks.results_tables import table
from benchmarks.separation import PAPER_ORDER, separation
from slam.campaign import run_campaign
from tests.small_worlds import small_world


def test_the_planar_ranking_is_the_campaigns() -> None:
    world = small_world(runs=3, filters=PAPER_ORDER, vehicle={"initial_sigma_heading_deg": 2.0},
                        sensor={"sigma_bearing_deg": 3.0})
    rep = separation(world)
    summary = run_campaign(world, workers=1).summary
    for key in ("position", "landmarks"):
        mine, theirs = rep["ranking"][key], summary["ranking"][key]
        assert mine["order"] == theirs["order"]
        for n in PAPER_ORDER:
            for field in ("mse", "delta_mse", "delta_se"):
                assert math.isclose(mine["rows"][n][field], theirs["rows"][n][field],
                                    rel_tol=1e-12, abs_tol=1e-15)
    pairs = {(c["metric"], c["better"], c["worse"]) for c in rep["paper_order"]}
    assert pairs == {(m, a, b) for m in ("position", "landmarks")
                     for a, b in (("srckf", "srukf"), ("srckf", "srcdkf"), ("srukf", "srcdkf"))}
    best = rep["ranking"]["position"]["best"]
    for c in rep["paper_order"]:
        if c["metric"] == "position" and c["better"] == best:
            worse = rep["ranking"]["position"]["rows"][c["worse"]]
            assert c["mean"] == pytest.approx(-worse["delta_mse"], rel=1e-12)
    assert set(rep["anees"]) == {*PAPER_ORDER, "gtsam"}
    for doc in (rep, summary):  # both render: one row per filter, each metric's best in bold
        md = table(doc).splitlines()
        rows = [line for line in md if line.startswith("| ") and "RMSE" not in line]
        assert [r.split(" | ")[0][2:] for r in rows] == summary["ranking"]["position"]["order"]
        assert sum(r.count("**") for r in rows) == 4 and all(r.count(" | ") == 4 for r in rows)
    assert sum(line.startswith("- position: srckf < srukf") for line in table(rep).splitlines()
               ) == 1


def test_a_kind_without_metrics_is_refused() -> None:
    with pytest.raises(SystemExit, match="ranks drone-slam and planar-slam"):
        separation("star-sensor", runs=1)
