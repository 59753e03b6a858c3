"""Golden summaries: small fixed-seed campaigns of every kind must reproduce the
``summary.json`` stored in ``tests/golden/`` (written by ``tests/golden/regenerate.py``).

Each campaign is re-run in-process (``slam.campaign.run_campaign(world, runs=..., seed=...,
workers=1)``; worlds from ``slam.registry.load_world``, the log from
``slam.registry.log_kind().open_log``), its summary taken through the renderer's strict JSON
with every key containing ``time`` removed, and compared with the stored file
(``golden_differences``): the same keys in the same order, ints/strings/booleans/nulls
exactly, floats to 1e-9 relative (BLAS/LAPACK builds and numpy's loops for another CPU may
round the last bits differently) with a 1e-12 absolute floor for rounding noise around
zero; the ranking's paired differences to 1e-9 of the MSEs they are differences of, and
the GTSAM smoother's rows to 1e-6 (defined to its LM stopping tolerance).  A refactoring
that keeps behaviour passes unchanged; a change meant to move the numbers regenerates the
files (``python -m tests.golden.regenerate``) and commits them with the change.  The five
campaigns together take about 12 s of CPU.
"""

from __future__ import annotations

import copy
import json

import pytest

from tests.golden import regenerate as golden


def test_the_golden_folder_holds_one_file_per_campaign():
    stored = {p.name for p in golden.HERE.glob("*.summary.json")}
    assert stored == {c.path.name for c in golden.CAMPAIGNS.values()}
    for c in golden.CAMPAIGNS.values():
        text = c.path.read_text(encoding="utf-8")
        data = json.loads(text, parse_constant=lambda t: pytest.fail(f"non-strict {t}"))
        assert golden.golden_text(data) == text  # written by the renderer's strict JSON
        assert golden.strip_timings(data) == data  # no timings stored
        assert data.get("seed", c.seed) == c.seed and data.get("runs", c.runs) == c.runs


def test_the_comparison_catches_what_it_should():
    """The comparison is strict where it says it is (so the golden test can fail)."""
    base = golden.load(golden.CAMPAIGNS["bailey-joint"])
    assert golden.differences(base, copy.deepcopy(base)) == []
    f = base["filters"]["ekf"]

    def changed(edit) -> list[str]:
        new = copy.deepcopy(base)
        edit(new["filters"]["ekf"])
        return golden.differences(base, new)

    assert changed(lambda e: e.update(anees=f["anees"] * (1 + 1e-10))) == []
    assert changed(lambda e: e.update(anees=f["anees"] * (1 + 1e-8)))
    assert changed(lambda e: e.update(runs_scored=3))
    assert changed(lambda e: e.update(runs_scored=2.0))  # int -> float is a change
    assert changed(lambda e: e.update(extra=1))  # a new key
    assert changed(lambda e: e.pop("nis_mean"))  # a dropped key
    assert changed(lambda e: e.update(pos_err_range_m={"y": e["pos_err_range_m"]["y"],
                                                       "x": e["pos_err_range_m"]["x"]}))
    assert changed(lambda e: e["anees_bounds_95"].append(3.0))
    assert changed(lambda e: e.update(anees=None))
    # rounding noise around zero is not a change; anything above the floor is
    assert golden.differences([3.5e-18], [0.0]) == [] and golden.differences([0.0], [1e-11])
    # the smoother's rows to 1e-6, the ranking's paired differences on their MSEs' scale
    assert golden.golden_differences(base, copy.deepcopy(base)) == []

    def moved(edit) -> list[str]:
        new = copy.deepcopy(base)
        edit(new)
        return golden.golden_differences(base, new)

    ref = base["reference"]["gtsam"]
    assert moved(lambda s: s["reference"]["gtsam"].update(anees=ref["anees"] * (1 + 1e-7))) == []
    assert moved(lambda s: s["reference"]["gtsam"].update(anees=ref["anees"] * (1 + 1e-5)))
    assert moved(lambda s: s["reference"]["gtsam"].update(extra=1))
    assert moved(lambda s: s["filters"]["ekf"].update(anees=f["anees"] * (1 + 1e-8)))
    row = next(iter(base["ranking"]["position"]["rows"].values()))
    assert moved(lambda s: next(iter(s["ranking"]["position"]["rows"].values())).update(
        delta_mse=row["delta_mse"] + 1e-3 * row["mse"]))
    assert moved(lambda s: next(iter(s["ranking"]["position"]["rows"].values())).update(
        mse=row["mse"] * (1 + 1e-8)))
    assert golden.strip_timings({"a": {"time_s": 1, "b": [{"x_time_y": 2, "c": 3}]}}) == {
        "a": {"b": [{"c": 3}]}}


@pytest.mark.parametrize("name", list(golden.CAMPAIGNS))
def test_campaign_reproduces_its_golden_summary(name):
    campaign = golden.CAMPAIGNS[name]
    new = golden.run(campaign)
    diff = golden.golden_differences(golden.load(campaign), new)
    assert not diff, (f"{name}: the summary moved ({len(diff)} differences; regenerate "
                      "with `python -m tests.golden.regenerate` only if that is intended):\n"
                      + "\n".join(diff[:20]))
