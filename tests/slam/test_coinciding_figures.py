"""Figures whose curves coincide say so: the planar and drone ``rmse_sigma.png`` and
``landmarks.png`` and the recorded log's ``map_state.png`` write, above their legend, which
estimators' curves lie within 1 % of each other and by how much
(:func:`slam.render.series.coincidence_note`).  A copy of a filter's scores under another
name coincides with it exactly; two different filters on the small planar world do not
coincide on the landmark NEES."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from slam.results import CampaignResult


def _with_copy(result: CampaignResult, name: str, copy: str) -> CampaignResult:
    """``result`` with filter ``name``'s scores, tracks and summary entry also under ``copy``."""
    summary = {**result.summary, "filters": {**result.summary["filters"],
                                             copy: result.summary["filters"][name]}}
    outcomes = [replace(o, scores={**o.scores, copy: o.scores[name]},
                        tracks={**o.tracks, copy: o.tracks[name]} if name in o.tracks
                        else o.tracks) for o in result.outcomes]
    return CampaignResult(result.world, summary, outcomes)


@pytest.fixture()
def notes(monkeypatch) -> list[str]:
    """The figure texts (notes) of every figure saved while the test runs."""
    seen: list[str] = []
    real = Figure.savefig

    def keep(fig, *a, **kw):
        seen.extend(t.get_text() for t in fig.texts)
        return real(fig, *a, **kw)

    monkeypatch.setattr(Figure, "savefig", keep)
    return seen


def _note(notes: list[str]) -> str:
    return " ".join(" ".join(n.split()) for n in notes if n.startswith("Overdrawn"))


def twin_panels(note: str, twin: str = "twin") -> set[str]:
    """The panels in which ``twin`` is named as coinciding with another estimator: a copy
    coincides exactly with its original in every panel, so it is paired in each (with the
    original or with an earlier estimator the original coincides with)."""
    out: set[str] = set()
    for a, b, cols in re.findall(r"(\S+) and (\S+) \(([^()]*)\)", note):
        if twin in (a, b):
            out |= {re.sub(r" -?[0-9.e+-]+( \S+)?$", "", c) for c in cols.split(", ")}
    return out


RMSE_PANELS = {"position x", "position y", "heading", "along-track", "cross-track",
               "position horizontal"}
MAP_PANELS = {"landmark RMSE", "landmark NEES / dof", "landmarks in the state",
              "map covariance trace"}


@pytest.mark.parametrize("figure", ["rmse_sigma.png", "landmarks.png"])
def test_planar_figures_name_coinciding_curves(planar_result, figure, notes, tmp_path: Path):
    from slam.kinds.planar.figures import figures

    figures()[figure][0](_with_copy(planar_result, "srckf", "twin"), tmp_path / figure)
    note = _note(notes)
    assert note.startswith("Overdrawn - curves that coincide, with their largest difference:")
    if figure == "rmse_sigma.png":  # every panel, the RMSE and the own σ
        assert twin_panels(note) == RMSE_PANELS | {f"{p} σ" for p in RMSE_PANELS}
        assert "srckf and twin (position x 0 m, position y 0 m, heading 0 deg" in note
    else:
        assert twin_panels(note) == MAP_PANELS
    notes.clear()
    figures()[figure][0](planar_result, tmp_path / f"plain-{figure}")
    assert "twin" not in _note(notes)


def test_drone_figures_name_coinciding_curves(drone_result, notes, tmp_path: Path):
    from slam.kinds.drone.figures import figures

    result = _with_copy(drone_result, "ekf", "twin")
    for figure in ("rmse_sigma.png", "landmarks.png"):
        notes.clear()
        figures()[figure][0](result, tmp_path / figure)
        panels = twin_panels(_note(notes))
        assert (MAP_PANELS <= panels if figure == "landmarks.png" else
                {"position x", "yaw", "position x σ"} <= panels), (figure, _note(notes))


def test_recorded_map_state_names_coinciding_curves(notes, tmp_path: Path):
    from slam.campaign import run_campaign
    from slam.kinds.recorded.figures import figures
    from slam.kinds.recorded.log import format_odometry_log
    from slam.registry import log_kind
    from tests.slam.kinds.recorded.synthetic import synthetic_log

    path = tmp_path / "small.txt"
    path.write_text(format_odometry_log(synthetic_log(np.random.default_rng(2), n_poses=60,
                                                      n_landmarks=5)))
    result = run_campaign(log_kind().open_log(path, ["ekf", "srckf"], None), workers=1)
    figures()["map_state.png"][0](_with_copy(result, "srckf", "twin"), tmp_path / "m.png")
    note = _note(notes)
    assert note.startswith("Overdrawn - map curves that coincide")
    assert twin_panels(note) == {"landmarks in the state", "map covariance trace"}
