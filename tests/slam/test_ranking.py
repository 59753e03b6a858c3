"""The paired ranking (:mod:`slam.ranking`) against a hand computation, and the decision
block (:mod:`slam.decision`) a kind's summary gets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.decision import Consistency, decide
from slam.ranking import ONE_RUN, Metric, paired, per_run_mse, rank
from slam.render.decision import decision_sections, decision_text, ranking_rows


def test_paired_difference_equals_a_hand_computation():
    # per-run MSE of three filters over four runs
    a = [1.0, 2.0, 3.0, 4.0]
    b = [1.5, 2.5, 2.9, 4.6]   # differences b - a: 0.5, 0.5, -0.1, 0.6
    c = [1.0, 2.0, 3.0, 4.0]   # identical to a
    out = rank(Metric("position", "position", "m", {"a": a, "b": b, "c": c}))
    d = np.array([0.5, 0.5, -0.1, 0.6])
    mean = d.sum() / 4                                        # 0.375
    se = math.sqrt(((d - mean) ** 2).sum() / 3) / 2           # sd / sqrt(4)
    assert out["best"] == "a" and out["order"][-1] == "b" and out["runs"] == 4
    rb = out["rows"]["b"]
    assert rb["delta_mse"] == pytest.approx(mean, rel=1e-12)
    assert rb["delta_se"] == pytest.approx(se, rel=1e-12)
    assert rb["z"] == pytest.approx(mean / se, rel=1e-12)
    assert rb["better_runs"] == 1
    assert rb["rmse"] == pytest.approx(math.sqrt(np.mean(b)))
    assert rb["delta_percent"] == pytest.approx(100 * (math.sqrt(np.mean(b) / 2.5) - 1))
    assert rb["verdict"] == ("separated" if mean / se > 3 else "significant"
                             if mean / se > 2 else "not significant")
    rc = out["rows"]["c"]
    assert rc["verdict"] == "equal" and rc["z"] is None and rc["z_reason"]
    assert rc["rank"] == out["rows"]["a"]["rank"] == 1 and out["order"][:2] == ["a", "c"]


def test_filters_equal_to_a_millionth_share_a_rank_and_are_listed_by_name():
    """A systematic 1e-8 difference (a differenced Jacobian's) is many standard errors but
    not a filter property: equal, one rank, alphabetical, whichever has the lower mean."""
    base = np.linspace(1.0, 2.0, 20)
    out = rank(Metric("att", "attitude", "arcsec", {"srckf": base * (1 + 1e-8), "ekf": base,
                                                    "srukf": base * 1.05}))
    assert out["order"] == ["ekf", "srckf", "srukf"]
    rows = out["rows"]
    assert rows["ekf"]["rank"] == rows["srckf"]["rank"] == 1 and rows["srukf"]["rank"] == 3
    assert rows["srckf"]["verdict"] == "equal" and rows["srukf"]["verdict"] == "separated"
    swapped = rank(Metric("att", "attitude", "arcsec", {"srckf": base, "ekf": base * (1 + 1e-8),
                                                        "srukf": base * 1.05}))
    assert swapped["order"] == ["ekf", "srckf", "srukf"] and swapped["best"] == "ekf"


def test_runs_a_filter_did_not_finish_are_left_out_of_every_pair():
    out = rank(Metric("p", "p", "m", {"a": [1.0, np.nan, 1.0, 1.0],
                                      "b": [2.0, 0.0, 2.0, 2.1]}))
    assert out["runs"] == 3 and out["best"] == "a"
    none = rank(Metric("p", "p", "m", {"a": [1.0, np.nan], "b": [np.nan, 1.0]}))
    assert none["runs"] == 0 and "reason" in none and "rows" not in none


def test_one_run_is_ordered_but_claims_no_significance():
    """A single paired run (a recorded log): the filters are ordered by their MSE, the
    standard error and z are null with their reason, and no verdict is a significance."""
    m = Metric("p", "position", "m", {"a": [4.0, np.nan], "b": [1.0, 2.0], "c": [1.0, 3.0],
                                      "d": [9.0, 9.0]})
    out = rank(m, ["a", "b", "d"])
    assert out["runs"] == 1 and out["significance"] == ONE_RUN
    assert out["order"] == ["b", "a", "d"] and out["best"] == "b"
    ra, rd = out["rows"]["a"], out["rows"]["d"]
    assert [out["rows"][n]["rank"] for n in out["order"]] == [1, 2, 3]
    assert ra["delta_mse"] == 3.0 and ra["delta_se"] is None and ra["z"] is None
    assert ra["delta_se_reason"].startswith(ONE_RUN) and ra["z_reason"]
    assert ra["verdict"] == rd["verdict"] == ONE_RUN and out["rows"]["b"]["verdict"] == "best"
    assert not set(LEVELS) & {r["verdict"] for r in out["rows"].values()}
    same = rank(Metric("p", "p", "m", {"a": [2.0], "b": [2.0]}))
    assert same["rows"]["b"]["verdict"] == "equal" and same["rows"]["b"]["rank"] == 1

    s = decide({"filters": {"a": {}, "b": {}, "d": {}}}, [m], filters=["a", "b", "d"],
               consistency=None, reference=None)
    assert s["headline"].startswith(f"Position: b has the lowest MSE on a single run (RMSE 1 m; "
                                    f"{ONE_RUN}); a +100.0 %, d +200.0 %.")
    assert "s.e." not in s["headline"] and ONE_RUN in decision_text(s)
    rows = ranking_rows(s["ranking"]["p"])
    assert rows[1][3] == "+3 m² (one run)" and rows[1][-1] == ONE_RUN
    assert not any("±" in c for r in rows for c in r)


LEVELS = ("significant", "separated", "not significant", "worse")


def test_paired_and_per_run_mse():
    p = paired(np.array([2.0, 3.0]), np.array([1.0, 1.0]))
    assert p["mean"] == 1.5 and p["se"] == pytest.approx(0.5) and p["a_better_runs"] == 0
    assert paired(np.array([1.0]), np.array([0.0]))["se"] is None
    err = np.array([[[3.0, 4.0], [np.nan, 0.0], [0.0, 0.0]]])   # (1 run, 3 epochs, 2)
    assert per_run_mse(err)[0] == pytest.approx(25.0 / 2)       # the NaN epoch left out
    assert per_run_mse(err, np.array([False, False, True]))[0] == 0.0


def test_decide_adds_ranking_headline_and_settings():
    rng = np.random.default_rng(0)
    base = rng.uniform(1.0, 2.0, 30)
    summary = {"filters": {
        "ekf": {"anees": 1.0, "anees_bounds_95": [0.8, 1.2], "anees_steps_inside_95": 0.95,
                "anees_steps_above_95": 0.03},
        "srukf": {"anees": 1.6, "anees_bounds_95": [0.8, 1.2], "anees_steps_inside_95": 0.2,
                  "anees_steps_above_95": 0.8}}}
    metric = Metric("position", "position", "m", {"ekf": base, "srukf": base * 1.2,
                                                  "gtsam": base * 0.5})
    out = decide(summary, [metric], filters=["ekf", "srukf"],
                 settings={"srukf": {"alpha": 1.0}}, settings_text={"srukf": "α = 1"},
                 variants={"srukf": "srukf-inv"})
    block = out["ranking"]["position"]
    assert block["best"] == "ekf" and block["rows"]["srukf"]["verdict"] == "separated"
    assert block["reference"]["best_over_reference"] == pytest.approx(math.sqrt(2.0))
    assert "ekf has the lowest MSE" in out["headline"]
    assert "Consistent (pose ANEES" in out["headline"] and "ekf." in out["headline"]
    assert "srukf-inv" in out["headline"]
    assert out["filters"]["srukf"]["settings"] == {"alpha": 1.0}
    assert summary["filters"]["srukf"].get("settings") is None  # the input is not changed

    class Tuned:  # a world's filters table gives the same settings
        def settings_of(self, name: str) -> dict:
            return {"alpha": 1.0} if name == "srukf" else {}

        def describe(self, name: str) -> str:
            return "α = 1" if name == "srukf" else ""

    by_table = decide(summary, [metric], filters=["ekf", "srukf"], tuned=Tuned(),
                      variants={"srukf": "srukf-inv"})
    assert by_table["filters"] == out["filters"]
    text = decision_text(out)
    assert "rank" in text and "separated" in text and "settings of srukf: α = 1" in text
    assert max(len(line) for line in text.splitlines()) <= 100
    titles = [s.title for s in decision_sections(out)]
    assert titles[0] == "Decision" and any(t.startswith("Ranking: position") for t in titles)
    assert Consistency().verdict(summary["filters"]["ekf"]) == "consistent"
