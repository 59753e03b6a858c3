"""Every registered kind decides: on a tiny campaign of its smallest bundled world (2 runs,
2 or 3 filters, cut short; the drone flies the tests' 30 m loop, ``small_drone_doc``: its
bundled worlds take half a minute even for one lap) its ``summary.json`` holds a
``ranking`` with rows and a ``headline``, and both the terminal output and ``report.md``
show a rank column and the headline.  A kind added to the registry without an entry in
:data:`CHEAP` fails here, as does a kind whose summary or report drops the decision.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from slam.campaign import run_campaign
from slam.registry import KINDS, get_kind, log_kind, world_from_dict
from slam.render import output
from slam.render.decision import HEADER
from slam.results import CampaignResult
from tests.slam.small_campaign import strict_loads
from tests.small_worlds import small_drone_doc
from worlds.loader import read_world

CHEAP: dict[str, tuple[str, dict[str, Any], tuple[str, ...]]] = {
    "planar-slam": ("bailey", {"vehicle.loops": 1}, ("ekf", "srckf")),
    "drone-slam": ("small-drone", {}, ("ekf", "srckf-inv")),
    "attitude": ("star-sensor", {"duration_s": 60.0, "scoring.steady_state_from_s": 30.0},
                 ("srckf", "ekf")),
    "ship": ("ship", {"duration_s": 8.0, "scoring.steady_state_from_s": 4.0},
             ("hommukf", "ukf", "cdkf")),
    "spinning": ("spinning", {"sample_interval_s": 1.0, "sweep.factors": [2.0],
                              "sweep.gammas_rad": [2.0], "sweep.scales": ["both"],
                              "sweep.runs_per_cell": 1, "sweep.filters": ["srckf", "ekf"]},
                 ("srckf", "ekf")),
    "alignment": ("alignment", {"duration_s": 3.0, "scoring.settled_from_s": 1.0,
                                "sweep.gammas": [5.0], "sweep.runs": 1}, ("ukf", "uthinf")),
    "fixed-wing": ("fixed-wing", {"duration_s": 20.0, "flight.manoeuvre_start_s": [5.0, 15.0],
                                  "flight.manoeuvre_ramp_s": [5.0, 4.0],
                                  "flight.turn_rate_deg_s": [0.0, 9.0],
                                  "flight.climb_deg": [0.0, 0.0],
                                  "flight.speed_mps": [25.0, 25.0]}, ("ins-ckf", "ins-ukf")),
}
"""Kind -> (its smallest bundled world, dotted-key overrides that make it cheap, filters)."""


def _put(table: dict[str, Any], dotted: str, value: Any) -> None:
    *path, key = dotted.split(".")
    for k in path:
        table = table.setdefault(k, {})
    table[key] = value


LOGS = ("recorded-log", "recorded-attitude", "ins-log")
"""The kinds that read a recorded log (one run each)."""


def _tiny(kind: str, tmp: Path) -> CampaignResult:
    if kind == "recorded-attitude":  # the first 3 s of the wheel's EqF log
        import gtsam

        from slam.registry import open_log

        lines = Path(gtsam.findExampleDataFile("EqFdata.csv")).read_text(
            encoding="utf-8").splitlines()
        path = tmp / "eqf3s.csv"
        path.write_text("\n".join(lines[:602]) + "\n", encoding="utf-8")
        return run_campaign(open_log(path, ["ekf", "srckf"], None, kind=get_kind(kind)),
                            workers=1)
    if kind == "ins-log":  # a synthetic 90 s IMU + GNSS turn, every 5th fix held out
        from slam.kinds.ins_log.synthetic import write_log
        from slam.registry import open_log

        return run_campaign(open_log(write_log(tmp), ["ekf", "srckf"], None,
                                     kind=get_kind(kind), holdout=5), workers=1)
    if kind == log_kind().name:  # a recorded log is one run: a small synthetic log
        from slam.kinds.recorded.log import format_odometry_log
        from tests.slam.kinds.recorded.synthetic import synthetic_log

        path = tmp / "small.txt"
        path.write_text(format_odometry_log(synthetic_log(np.random.default_rng(2),
                                                          n_poses=60, n_landmarks=5)))
        return run_campaign(log_kind().open_log(path, ["ekf", "srckf"], None), workers=1)
    name, overrides, filters = CHEAP[kind]
    doc = small_drone_doc() if name == "small-drone" else copy.deepcopy(read_world(name).data)
    for dotted, value in overrides.items():
        _put(doc, dotted, value)
    world = world_from_dict(doc, name=f"tiny-{name}")
    return run_campaign(world, filters=filters, runs=2, seed=0, workers=1)


@pytest.fixture(scope="module", params=sorted(KINDS))
def decided(request, tmp_path_factory) -> tuple[str, dict[str, Any], str, str]:
    """Each kind's tiny campaign: its summary.json, terminal text and report.md."""
    kind = request.param
    tmp = tmp_path_factory.mktemp(kind)
    result = _tiny(kind, tmp)
    report = get_kind(kind).report
    output.write_outputs(result, report, tmp / "out", plots=False)
    summary = strict_loads((tmp / "out" / "summary.json").read_text(encoding="utf-8"))
    md = (tmp / "out" / "report.md").read_text(encoding="utf-8")
    return kind, summary, report.text_table(summary), md


def test_every_kind_has_a_cheap_world() -> None:
    assert set(CHEAP) | set(LOGS) == set(KINDS)


def test_summary_report_and_terminal_decide(decided) -> None:
    kind, summary, text, md = decided
    ranking, headline = summary.get("ranking"), summary.get("headline")
    assert ranking and isinstance(headline, str) and headline, kind
    ranked = [b for b in ranking.values() if b.get("rows")]
    assert ranked, (kind, ranking)
    runs = 1 if kind in LOGS else 2
    for block in ranked:
        assert block["runs"] == runs and block["order"][0] == block["best"]
        assert [block["rows"][n]["rank"] for n in block["order"]][0] == 1
        assert len(block["rows"]) >= 2, (kind, block)
    flat = " ".join(text.split())  # the terminal wraps the headline
    assert " ".join(headline.split()[:8]) in flat, kind
    assert any(line.split()[:2] == ["rank", "filter"] for line in text.splitlines()), kind
    assert headline in md, kind
    assert "| " + " | ".join(HEADER) + " |" in md, kind
    if runs == 1:
        assert "one run: no significance" in headline
