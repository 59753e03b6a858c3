"""The drone kind end to end (:mod:`slam.kinds.drone.run`, :mod:`slam.kinds.drone.report`):
one run, the summary, figures, the 3-D scene, the report folder.
"""

from __future__ import annotations

import json
import math

import numpy as np
import trimesh

from slam.kinds.drone.filtering import IMU_ONLY
from slam.kinds.drone.report import REPORT, drone_text_table, write_scene_glb
from slam.render.output import write_outputs
from slam.results import REFERENCE
from tests.small_worlds import DRONE_FILTERS

FILTERS = DRONE_FILTERS


def test_small_world_runs_the_whole_pipeline(drone_result, tmp_path):
    """One run of every filter (the session's ``drone_result``): the summary, the 3-D scene,
    the terminal table and the report folder (its figures are checked with every kind's in
    ``tests/slam/test_reports.py``).  (How fast this is belongs in ``benchmarks/``.)"""
    result = drone_result
    summary = result.summary
    glb = write_scene_glb(result, tmp_path / "scene.glb")
    for name in FILTERS:
        entry = summary["filters"][name]
        assert entry["diverged_runs"] == 0
        assert set(entry["pos_err_range_m"]) == {"x", "y", "z"}
        assert entry["pos_rmse_m"] < 1.0 and entry["landmark_rmse_m"] < 1.0
        assert {"anees", "anees_bounds_95", "anees_steps_inside_95", "anees_steps_above_95",
                "anees_pose6", "nis_mean", "time_per_step_s"} <= set(entry)
        assert set(entry["att_rmse_deg"]) == {"roll", "pitch", "yaw"}
    assert summary["reference"][REFERENCE]["pos_rmse_m"] < 1.0
    assert summary["baselines"][IMU_ONLY]["pos_rmse_m"] > summary["filters"]["srckf"][
        "pos_rmse_m"]
    assert "landmark_rmse_vs_gtsam" in summary["filters"]["srckf"]
    json.dumps(summary)
    scene = trimesh.load(glb)
    assert isinstance(scene, trimesh.Scene) and "terrain" in scene.geometry
    table = drone_text_table(summary)
    assert "pos RMSE" in table and IMU_ONLY in table and REFERENCE in table
    assert max(len(line) for line in table.splitlines()) <= 100
    out = tmp_path / "report"
    names = [p.name for p in write_outputs(result, REPORT, out, plots=False)]
    assert {"summary.json", "report.md", "report.html", "scene.glb", "truth.tum"} <= set(names)
    assert REPORT.text_table(summary) == table
    md = (out / "report.md").read_text()
    assert "z paper (m)" in md and "[-0.50, +0.05]" in md and "z range (m)" in md
    assert math.isfinite(json.loads((out / "summary.json").read_text())["filters"]["srckf"][
        "pos_rmse_m"])


def test_scores_carry_the_figure_series(drone_result):
    """Every filter's scores hold the per-epoch arrays the figures draw (velocity and bias
    σ, bias errors, attitude NEES, along/cross-track, NIS epochs, the map series)."""
    first = drone_result.outcomes[0]
    E = len(first.times)
    for name in FILTERS:
        s = first.scores[name]
        for attr, shape in (("sig_vel", (E, 3)), ("err_bias", (E, 6)), ("sig_bias", (E, 6)),
                            ("nees_att", (E,)), ("err_track", (E, 2)), ("sig_track", (E, 2))):
            a = getattr(s, attr)
            assert a.shape == shape and a.dtype == np.float32, (name, attr)
            assert np.isfinite(a[1:]).all(), (name, attr)
        assert len(s.nis_epoch) == len(s.nis) and s.nis_epoch.max() < E
        m = s.map_series
        assert m.n[-1] == len(s.lm_ids) and m.scored[-1] == m.n[-1] and m.trace[-1] > 0
        # the map's last squared error is the final landmark errors' (single precision)
        np.testing.assert_allclose(m.sq_err[-1], np.sum(s.lm_err**2), rtol=1e-5)
