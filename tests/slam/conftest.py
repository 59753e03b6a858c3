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
