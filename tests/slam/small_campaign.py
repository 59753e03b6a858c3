"""Test helper (not a test module): a small planar campaign with a quoted paper, shared by
the renderer's tests and the planar report's tests through the session fixtures
``planar_result`` and ``planar_written`` of ``tests/slam/conftest.py``.
"""

from __future__ import annotations

import json
import math

import numpy as np

from slam.campaign import run_campaign
from slam.results import CampaignResult
from tests.small_worlds import small_world

FILTERS = ("ekf", "srckf")
ROWS = [*FILTERS, "odometry", "gtsam"]
PAPER = {
    "source": "test paper, Fig. 1",
    "filters": {"srckf": {"pos_err_range_m": {"x": [-0.5, 0.6], "y": [-0.5, 0.2]}},
                "srukf": {"pos_err_range_m": {"x": [-0.7, 1.4], "y": [-1.15, 1.6]}}},
}
FIGURES = {"map.png", "errors_xy.png", "rmse_sigma.png", "nees.png", "landmarks.png",
           "differences.png"}


def _reject_constant(name: str):
    raise ValueError(f"non-strict JSON token {name}")


def strict_loads(text: str):
    return json.loads(text, parse_constant=_reject_constant)


def plain(obj):
    """The test's own conversion of a summary to what JSON should hold."""
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [plain(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def sample_provenance(summary: dict, source: str | None) -> dict:
    """A provenance block as the command line would add it (fixed date and wall time)."""
    import datetime as dt

    from slam.render.provenance import provenance

    return provenance(argv=["slam", "run", source or "log.txt", "--workers", "1"],
                      source=source, seed=summary.get("seed"), runs=summary.get("runs"),
                      workers=1, started=dt.datetime(2026, 1, 2, 3, 4, 5, tzinfo=dt.UTC),
                      wall_time_s=1.25)


def small_planar_result() -> CampaignResult:
    """Two runs of ekf and srckf on the small planar world, with :data:`PAPER` quoted and a
    provenance block."""
    world = small_world(runs=2, filters=FILTERS)
    r = run_campaign(world, runs=2, workers=1)
    summary = {**r.summary, "paper": PAPER}
    summary["provenance"] = sample_provenance(summary, "small.toml")
    return CampaignResult(r.world, summary, r.outcomes)
