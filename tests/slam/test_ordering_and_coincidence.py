"""A paper's claimed ordering tested by the paired statistic (:func:`slam.ranking.ordering`)
against a hand computation, its report rows, and the coinciding-curves rule the figures'
notes use (:func:`slam.render.series.coinciding`)."""

from __future__ import annotations

import math

import numpy as np

from slam.ranking import Metric, ordering
from slam.render.decision import ordering_rows, ordering_section
from slam.render.series import coincidence_note, coinciding


def test_ordering_against_a_hand_computation() -> None:
    a = np.array([1.0, 2.0, 1.5, np.nan, 1.0])
    b = np.array([2.0, 3.0, 2.0, 5.0, 1.5])
    out = ordering(Metric("p", "position", "m", {"a": a, "b": b}), "a", "b")
    d = np.array([-1.0, -1.0, -0.5, -0.5])  # run 3 left out (a did not finish it)
    assert out["runs"] == 4 and out["a_better_runs"] == 4
    assert math.isclose(out["mean"], d.mean()) and math.isclose(
        out["se"], d.std(ddof=1) / 2.0)
    assert math.isclose(out["z"], d.mean() / (d.std(ddof=1) / 2.0))
    assert out["verdict"] == "reproduced"  # z = -5.2
    assert math.isclose(out["rmse_better"], math.sqrt(5.5 / 4))
    assert math.isclose(out["rmse_worse"], math.sqrt(8.5 / 4))
    rev = ordering(Metric("p", "position", "m", {"a": a, "b": b}), "b", "a")
    assert rev["verdict"] == "reversed" and math.isclose(rev["mean"], -out["mean"])
    noisy = ordering(Metric("p", "p", "m", {"a": [1.0, 3.0, 1.5], "b": [2.0, 1.0, 2.0]}),
                     "a", "b")
    assert noisy["verdict"] == "not significant"
    same = ordering(Metric("p", "p", "m", {"a": [1.0, 2.0], "b": [1.0, 2.0]}), "a", "b")
    assert same["verdict"] == "equal" and same["z"] is None and same["z_reason"]
    one = ordering(Metric("p", "p", "m", {"a": [1.0, np.nan], "b": [2.0, 1.0]}), "a", "b")
    assert one["verdict"] is None and "at least 2" in one["verdict_reason"]


def test_ordering_rows_and_section() -> None:
    m = Metric("level", "level", "′", {"u": [1.0, 1.1, 0.9], "k": [1.2, 1.3, 1.0]})
    summary = {"paper_ordering": [ordering(m, "u", "k")]}
    (row,) = ordering_rows(summary)
    assert row[0] == "u beats k" and row[-1] == "reproduced" and row[5] == "3"
    assert row[3].startswith("-0.167 ± ") and row[3].endswith("′²")
    sec = ordering_section(summary, "The paper says so.")
    assert sec is not None and sec.text.startswith("The paper says so.")
    assert ordering_section({}) is None


def test_coinciding_curves() -> None:
    t = np.linspace(0.0, 1.0, 50)
    base = np.sin(6 * t) + 2.0
    curves = {"a": base, "b": base + 0.001, "c": base * 1.5, "d": None,
              "e": np.where(t > 0.5, base, np.nan), "f": base[::2]}
    pairs = coinciding(curves)
    assert [(a, b) for a, b, _ in pairs] == [("a", "b"), ("a", "e")]
    assert math.isclose(pairs[0][2], 0.001, rel_tol=1e-6) and pairs[1][2] == 0.0
    note = coincidence_note({"x": {"a": base, "b": base + 0.001},
                             "y": {"a": base, "b": base + 0.002, "c": base * 1.5}},
                            {"x": "m", "y": "m/s"}, "run 0's curves")
    assert note == ("Overdrawn - run 0's curves that coincide, with their largest difference: "
                    "a and b (x 0.001 m, y 0.002 m/s).")
    assert coincidence_note({"x": {"a": base, "c": base * 1.5}}, {"x": "m"}) == ""
