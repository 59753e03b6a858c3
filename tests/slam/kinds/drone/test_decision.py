"""The drone's decision (:func:`slam.kinds.drone.run.summarize_drone`): the paired ranking
by position, yaw and final landmarks against a hand computation from the runs' scores, the
filters' settings, the landmark ANEES, and the invariant-variant line when a standard
filter is optimistic."""

from __future__ import annotations

import numpy as np
import pytest

import slam.kinds.drone.run as drone_run
from slam.ranking import ONE_RUN
from slam.results import REFERENCE


def test_ranking_metrics_settings_and_map_consistency(drone_result):
    r = drone_result
    s = drone_run.summarize_drone(r.world, r.outcomes, ["ekf", "srckf", "srukf"], 1, 11)
    assert set(s["ranking"]) == {"position", "yaw", "landmarks"}
    scores = r.outcomes[0].scores
    hand = {"position": lambda x: np.mean(np.sum(x.err_pos**2, axis=1)),
            "yaw": lambda x: np.nanmean(np.degrees(x.err_att[:, 2]) ** 2),
            "landmarks": lambda x: np.mean(x.lm_err**2)}
    for key, fn in hand.items():
        block = s["ranking"][key]
        assert block["runs"] == 1 and block["significance"] == ONE_RUN
        assert set(block["rows"]) == {"ekf", "srckf", "srukf"}  # the smoother is not ranked
        mse = {n: fn(scores[n]) for n in block["rows"]}
        assert block["order"] == sorted(mse, key=mse.get)
        for n, row in block["rows"].items():
            assert row["mse"] == pytest.approx(mse[n], rel=1e-12)
            assert row["verdict"] in ("best", "equal", ONE_RUN) and row["delta_se"] is None
        assert block["reference"]["name"] == REFERENCE
        assert block["reference"]["rmse"] == pytest.approx(np.sqrt(fn(scores[REFERENCE])),
                                                           rel=1e-12)
    assert s["headline"].startswith("Position: ")
    assert s["filters"]["srukf"]["settings"] == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert s["filters"]["ekf"]["settings"] == {}
    for name in ("ekf", "srckf", "srukf"):
        e = s["filters"][name]
        lo, hi = e["landmark_anees_bounds_95"]
        assert e["landmark_anees_dof"] == 3 and 0 < lo < 1 < hi
        assert 0.0 <= e["landmark_anees_steps_inside_95"] <= 1.0 and e["landmark_anees"] > 0


def test_an_optimistic_filter_is_pointed_to_its_invariant_variant(drone_result, monkeypatch):
    real = drone_run.summarize_scores

    def optimistic_ekf(scores, *a, **kw):
        out = real(scores, *a, **kw)
        if scores and scores[0].name == "ekf":
            out["anees"] = 50.0 * out["anees_bounds_95"][1]
        return out

    monkeypatch.setattr(drone_run, "summarize_scores", optimistic_ekf)
    r = drone_result
    s = drone_run.summarize_drone(r.world, r.outcomes, ["ekf", "srckf"], 1, 11)
    assert "ekf is optimistic" in s["headline"]
    assert "invariant-error variant ekf-inv (--filters ekf-inv)" in s["headline"]
    assert "srckf is optimistic" not in s["headline"]
