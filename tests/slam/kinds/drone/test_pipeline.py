"""The drone kind end to end (:mod:`slam.kinds.drone.run`, :mod:`slam.kinds.drone.report`):
one run, the summary, figures, the 3-D scene, the report folder.
"""

from __future__ import annotations

import json
import math

import numpy as np
import trimesh

from slam.kinds.drone.filtering import IMU_ONLY
from slam.kinds.drone.report import (
    REPORT,
    drone_figures,
    drone_text_table,
    write_scene_glb,
)
from slam.kinds.drone.run import run_once, summarize_drone
from slam.render.output import write_outputs
from slam.results import REFERENCE, CampaignResult
from tests.small_worlds import DRONE_FILTERS, small_drone_world

FILTERS = DRONE_FILTERS


def test_small_world_runs_the_whole_pipeline(tmp_path):
    """One run of every filter, the summary, figures, the 3-D scene and the report folder.
    (How fast this is belongs in ``benchmarks/``, not in a pass/fail test.)"""
    w = small_drone_world()
    seeds = np.random.SeedSequence(11).spawn(1)
    outs = [run_once(w, 0, seeds[0], list(FILTERS), True)]
    summary = summarize_drone(w, outs, list(FILTERS), 1, 11)
    result = CampaignResult(w, summary, outs)
    figures = drone_figures(result, tmp_path)
    glb = write_scene_glb(result, tmp_path / "scene.glb")
    for name in FILTERS:
        entry = summary["filters"][name]
        assert entry["diverged_runs"] == 0
        assert set(entry["pos_err_range_m"]) == {"x", "y", "z"}
        assert entry["pos_rmse_m"] < 1.0 and entry["landmark_rmse_m"] < 1.0
        assert {"anees", "anees_bounds_95", "anees_pose6", "nis_mean",
                "time_per_step_s"} <= set(entry)
        assert set(entry["att_rmse_deg"]) == {"roll", "pitch", "yaw"}
    assert summary["reference"][REFERENCE]["pos_rmse_m"] < 1.0
    assert summary["baselines"][IMU_ONLY]["pos_rmse_m"] > summary["filters"]["srckf"][
        "pos_rmse_m"]
    assert "landmark_rmse_vs_gtsam" in summary["filters"]["srckf"]
    json.dumps(summary)
    for f in figures:
        assert (tmp_path / f).stat().st_size > 10_000
    scene = trimesh.load(glb)
    assert isinstance(scene, trimesh.Scene) and "terrain" in scene.geometry
    table = drone_text_table(summary)
    assert "z range" in table and IMU_ONLY in table and REFERENCE in table
    out = tmp_path / "report"
    names = [p.name for p in write_outputs(result, REPORT, out, plots=False)]
    assert {"summary.json", "report.md", "report.html", "scene.glb", "truth.tum"} <= set(names)
    assert REPORT.text_table(summary) == table
    md = (out / "report.md").read_text()
    assert "z paper (m)" in md and "[-0.50, +0.05]" in md
    assert math.isfinite(json.loads((out / "summary.json").read_text())["filters"]["srckf"][
        "pos_rmse_m"])
