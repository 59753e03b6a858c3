"""The summary's null convention (:mod:`slam.nulls`): the check itself, and a small campaign
of every kind plus degenerate worlds (no turns, fixes far apart, a zero-length lap, no blind
area, a sweep without logs, an attitude that never converges) - no null without its reason
beside it, and no numpy or matplotlib warning from the run, the summary or the report."""

from __future__ import annotations

import math
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from slam.campaign import run_campaign
from slam.nulls import unexplained_nulls
from slam.registry import get_kind, log_kind
from slam.render.tables import jsonable
from slam.results import CampaignResult


def test_the_check_finds_every_null_without_its_reason() -> None:
    s = {"a": None, "b": math.nan, "c": [1.0, None], "d": {"e": {"f": None}},
         "g": None, "g_reason": "why", "h": None, "h_reason": None, "i": None, "i_reason": " ",
         "seg": {"x": None, "epochs": 0}, "seg2": {"x": None, "epochs": 3},
         "win": {"epochs": [0, 2], "east": [None, 1.0], "north": [None, None]},
         "conv": {"max": None, "converged_runs": 0}, "none": {"runs_scored": 0, "y": None},
         "rows": [{"z": None, "z_reason": "no γ"}, {"z": None}], "flag": False, "zero": 0}
    assert unexplained_nulls(s) == [
        "a", "b", "c[1]", "d.e.f", "h", "h_reason", "i", "seg2.x", "win.north[1]", "rows[1].z"]
    assert unexplained_nulls({"k": np.float64(np.inf), "n": np.array([1.0, np.nan])}) == [
        "k", "n[1]"]
    assert unexplained_nulls({"epochs": False, "x": None}) == ["x"]  # a bool is no count


# --------------------------------------------------------------------------- every kind


def _recorded():
    from slam.kinds.recorded.log import format_odometry_log
    from tests.slam.kinds.recorded.synthetic import synthetic_log

    path = Path(tempfile.mkdtemp()) / "small.txt"
    path.write_text(format_odometry_log(synthetic_log(np.random.default_rng(2), n_poses=30,
                                                      n_landmarks=4)))
    return log_kind().open_log(path, ["ekf", "srckf"], None)


def _ship():
    from tests.slam.kinds.ship.worlds import ship_world

    return ship_world(8.0, runs=2, **{"filters.names": ["hommukf", "srckf"],
                                      "filters.paper_model": ["hommukf"]})


def _spinning(**overrides: Any):
    from tests.slam.kinds.spinning.helpers import tiny_world

    return tiny_world(**{"runs": 1, **overrides})


def _alignment():
    from tests.slam.kinds.alignment.worlds import alignment_world

    return alignment_world(3.0, runs=2)


def _fixed_wing(**overrides: Any):
    from tests.slam.kinds.fixed_wing.worlds import short_world

    return short_world(**{"duration_s": 20.0, "runs": 1,
                          "filters.names": ["ea-ckf", "ins-ekf"], **overrides})


def _level_flight():
    from tests.slam.kinds.fixed_wing.worlds import LEVEL_FLIGHT, fw_world

    return fw_world(**LEVEL_FLIGHT, duration_s=20.0, runs=1,
                    **{"filters.names": ["ea-ckf", "ins-ekf"]})


def _fixes_far_apart():
    from tests.slam.kinds.fixed_wing.worlds import turn_between_fixes

    return turn_between_fixes(**{"filters.names": ["ins-ekf"]})


def _planar_zero_lap():
    from tests.small_worlds import small_world

    return small_world(runs=1, waypoints=[[10.0, 10.0], [10.0, 10.0]], vehicle={"loops": 2})


def _attitude_never_converges():
    from tests.small_worlds import short_star_sensor_world

    return short_star_sensor_world(4.0, **{"runs": 1, "scoring.report_convergence": True,
                                           "filters.names": ["ekf"],
                                           "star_sensor.sigma_arcsec": 1000.0})


WORLDS: dict[str, Callable[[], Any]] = {
    "recorded-log": _recorded,
    "ship": _ship,
    "spinning": _spinning,
    "alignment (azimuth not observable, smoother's first window empty)": _alignment,
    "fixed-wing": _fixed_wing,
    "fixed-wing, no turn and no acceleration": _level_flight,
    "fixed-wing, a turn between GNSS fixes 10 s apart": _fixes_far_apart,
    "planar, a zero-length lap flown twice": _planar_zero_lap,
    "spinning, no blind area": lambda: _spinning(**{"field.inclination_deg": 90.0}),
    "spinning, all blind, a sweep without logs": lambda: _spinning(
        **{"scoring.blind_area_deg": 90.0, "sweep.runs_per_cell": 0}),
    "spinning, a given drag far from the targets": lambda: _spinning(
        **{"flight.drag_k_per_m": 1e-3}),
    "attitude, never below 1 arcmin": _attitude_never_converges,
}


def _rendered(result: CampaignResult) -> dict[str, Any]:
    """The summary as ``summary.json`` holds it, after the report's text is rendered."""
    summary = jsonable(result.summary)
    report = get_kind(summary["kind"]).report
    assert report.markdown(summary) and report.text_table(summary)
    return summary


@pytest.mark.parametrize("name", list(WORLDS))
def test_a_small_campaign_explains_every_null_and_warns_nothing(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy / matplotlib warning fails the test
        summary = _rendered(run_campaign(WORLDS[name](), workers=1))
    assert unexplained_nulls(summary) == []


@pytest.mark.parametrize("fixture", ["planar_result", "drone_result", "attitude_result"])
def test_the_sessions_campaigns_explain_every_null(fixture: str, request) -> None:
    """The planar, drone and star-sensor campaigns the other tests share."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        summary = _rendered(request.getfixturevalue(fixture))
    assert unexplained_nulls(summary) == []
