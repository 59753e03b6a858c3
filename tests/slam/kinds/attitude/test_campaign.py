"""Star-sensor campaigns: the convergence time, and a small campaign end to end (summary,
tables, figures, report sections).
"""

from __future__ import annotations

import json
import math

import numpy as np

import slam.kinds.attitude.run as att

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]

def test_convergence_time() -> None:
    t = np.arange(6.0)
    assert att.convergence_time(np.array([5, 3, 0.5, 2, 0.5, 0.1]), t, 1.0) == 4.0
    assert att.convergence_time(np.array([0.5, 0.1, 0.2, 0.1, 0.5, 0.1]), t, 1.0) == 0.0
    assert math.isnan(att.convergence_time(np.array([0.5, 0.1, 0.2, 0.1, 0.5, 3]), t, 1.0))


# --------------------------------------------------------------------------- campaign


def test_small_campaign_end_to_end(attitude_result) -> None:
    """The session's small campaign (``attitude_result``): summary, tables, report sections
    (its figures are checked with every kind's in ``tests/slam/test_reports.py``)."""
    from slam.kinds.attitude.figures import figure_specs
    from slam.kinds.attitude.report import REPORT

    result = attitude_result
    w = result.world
    s = result.summary
    assert s["kind"] == "attitude" and s["runs"] == 3 and s["steady_state_window_s"] == [30, 60]
    assert set(s["filters"]) == set(FILTERS) and s["paper"] == w.paper
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, name
        for key in ("att_mean_abs_arcsec", "att_mean_abs_steady_arcsec", "att_rms_steady_arcsec"):
            assert set(e[key]) == {"roll", "pitch", "yaw"}
            assert all(0.0 < v < 30.0 for v in e[key].values()), (name, key, e[key])
        assert 0.0 < e["bias_rmse_deg_h"] < 5.0
        lo, hi = e["anees_bounds_95"]
        assert lo < 1.0 < hi and 0.0 < e["anees"] < 10.0
        assert e["converge_below_1arcmin_s"] is not None
    for e in s["filters"].values():
        assert e["time_per_cycle_s"] > 0.0
    assert s["reference"]["gtsam"]["time_s"] > 0.0
    json.dumps(s, allow_nan=False)
    table = REPORT.markdown(s)
    assert "srckf" in table and "Paper's Table 2" in table and "ekf (MEKF)" in table
    titles = [sec.title for sec in REPORT.sections(s)]
    assert titles[0] == "Decision" and titles[1].startswith("Ranking: attitude")
    assert titles[2].startswith("Ranking: gyro bias")
    assert titles[3:7] == ["The paper's ordering, tested", "Filter settings", "Results",
                           "Convergence"] and titles[-1] == "How to read this"
    assert set(REPORT.figures()) == {spec.name for spec in figure_specs()}
    text = REPORT.text_table(s)
    assert "srckf" in text and "(deg/h)" in text
    assert max(len(line) for line in text.splitlines()) <= 100
