"""Fixtures shared by the tests of :mod:`slam` (the renderer's and the kinds' reports)."""

from __future__ import annotations

from pathlib import Path

import pytest

from slam.results import CampaignResult
from tests.slam.small_campaign import small_planar_result


@pytest.fixture(scope="session")
def planar_result() -> CampaignResult:
    """:func:`~tests.slam.small_campaign.small_planar_result`, computed once per session."""
    return small_planar_result()


@pytest.fixture(scope="session")
def planar_written(planar_result, tmp_path_factory) -> tuple[Path, list[Path]]:
    """The planar report folder of :func:`planar_result`, written once per session."""
    from slam.kinds.planar import report
    from slam.render import output

    out = tmp_path_factory.mktemp("report") / "small"
    return out, output.write_outputs(planar_result, report.REPORT, out)


@pytest.fixture(scope="session")
def drone_result() -> CampaignResult:
    """One run of every drone filter on the small drone world (seed 11), once per session;
    shared by the drone pipeline test and the report tests."""
    from slam.campaign import run_campaign
    from tests.small_worlds import DRONE_FILTERS, small_drone_world

    return run_campaign(small_drone_world(), filters=DRONE_FILTERS, runs=1, seed=11, workers=1)


@pytest.fixture(scope="session")
def attitude_result() -> CampaignResult:
    """Three runs of the star-sensor world cut to 60 s, with the convergence scored, once per
    session; shared by the attitude campaign test and the report tests."""
    from slam.campaign import run_campaign
    from tests.small_worlds import short_star_sensor_world

    w = short_star_sensor_world(60.0, **{"runs": 3, "scoring.report_convergence": True})
    return run_campaign(w, workers=1)
