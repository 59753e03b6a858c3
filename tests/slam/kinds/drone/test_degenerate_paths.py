"""Degenerate drone paths: a lap flown in no time (every waypoint the same point) is a world
error naming ``map.waypoints`` - one line, exit 2, nothing written - and the per-lap
summary of a lap without epochs is null with its reason, not a traceback."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from benchmarks.fuzz.tomlio import dumps
from slam.campaign import run_campaign
from slam.kinds.drone.scoring import summarize_scores
from slam.nulls import unexplained_nulls
from tests.small_worlds import small_drone_doc, small_drone_world
from worlds import WorldError

MAP = {"bounds_m": [-20.0, 50.0, -20.0, 50.0],
       "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]]}
SAME_POINT = {"four identical": [[10.0, 10.0]] * 4, "two identical": [[10.0, 10.0]] * 2,
              "within at_waypoint_m": [[10.0, 10.0], [10.0, 10.5]]}


@pytest.mark.parametrize("waypoints", list(SAME_POINT.values()), ids=list(SAME_POINT))
def test_a_lap_without_a_sensor_epoch_is_a_world_error(waypoints) -> None:
    w = small_drone_world(map={**MAP, "waypoints": waypoints}, vehicle={"loops": 2},
                          filters={"names": ["ekf"]}, runs=1)
    with pytest.raises(WorldError) as err:
        run_campaign(w, runs=1, workers=1)
    assert err.value.key == "map.waypoints"
    assert "lap 2 of 2 lasts 0 s and holds no sensor epoch (period 0.2 s)" in str(err.value)


def test_one_lap_to_a_single_point_is_still_a_world() -> None:
    """``loops = 1``: the flight to the point is the lap; it has epochs."""
    w = small_drone_world(map={**MAP, "waypoints": SAME_POINT["two identical"]},
                          filters={"names": ["ekf"]}, runs=1)
    assert run_campaign(w, runs=1, workers=1).summary["filters"]["ekf"]["runs_scored"] == 1


def test_the_command_line_refuses_it_in_one_line_and_writes_nothing(tmp_path) -> None:
    doc = small_drone_doc(map={**MAP, "waypoints": SAME_POINT["two identical"]},
                          vehicle={"loops": 3}, filters={"names": ["ekf"]}, runs=1)
    doc.pop("paper")
    path = tmp_path / "same-point.toml"
    path.write_text(dumps(doc), encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--workers", "1", "--out",
                                             str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: [map] waypoints: lap 2 of 3")
    assert not out.exists()


def test_a_lap_with_no_epoch_in_a_summary_is_null_with_its_reason(drone_result) -> None:
    """A second lap ending where the first does (what a zero-length lap gave the summary:
    ``np.nanmax`` of an empty array raised)."""
    o = drone_result.outcomes[0]
    end = float(o.times[-1])
    s = summarize_scores([o.scores["srckf"]], o.times, [end, end])
    assert s["loop_epochs"] == [len(o.times), 0]
    assert s["loop_pos_rmse_m"][1] is None and s["loop_pos_max_err_m"][1] is None
    assert s["loop_pos_rmse_m"][0] == pytest.approx(s["pos_rmse_m"])
    assert s["loop_pos_max_err_m"][0] == pytest.approx(
        float(np.max(np.linalg.norm(o.scores["srckf"].err_pos, axis=1))))
    assert "lap(s) [2]" in s["loop_pos_rmse_m_reason"]
    assert unexplained_nulls(s) == []
