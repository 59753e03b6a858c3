"""Every kind's report on a small campaign (planar, drone, star sensor, recorded log): the
figure set its specs promise and nothing else, every drawn panel's axes labelled, the
provenance block in ``summary.json``, ``report.md`` and ``report.html``, the HTML's links
resolving to files of the folder, and a terminal table that fits 100 columns.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from slam.registry import get_kind, log_kind
from slam.render import output
from slam.results import CampaignResult
from tests.slam.small_campaign import sample_provenance, strict_loads

FIGURES = {
    "planar-slam": ["map.png", "errors_xy.png", "rmse_sigma.png", "nees.png",
                    "landmarks.png", "differences.png"],
    "drone-slam": ["errors_xyz.png", "attitude.png", "rmse_sigma.png", "bias.png", "nees.png",
                   "landmarks.png", "differences.png", "drift.png", "view3d.png"],
    "attitude": ["attitude_errors.png", "convergence.png", "rmse_sigma.png", "bias.png",
                 "nees.png", "differences.png"],
    "recorded-log": ["trajectories.png", "aligned_map.png", "pose_diff.png", "map_state.png"],
}
EXTRA = {"planar-slam": {"truth.tum", "srckf.tum"}, "drone-slam": {"scene.glb", "truth.tum"},
         "attitude": {"truth.tum", "srckf.tum", "srckf.cov.txt"},
         "recorded-log": {"gtsam.tum", "srckf.tum", "odometry.tum"}}
PROVENANCE_KEYS = {"package", "version", "git_commit", "git_dirty", "command", "world_file",
                   "world_sha256", "seed", "runs", "started_utc", "wall_time_s", "workers",
                   "scheduler", "python", "libraries"}


@pytest.fixture(scope="module")
def recorded_result(tmp_path_factory) -> CampaignResult:
    """The recorded-log kind on a small synthetic log (one run, tracks kept)."""
    from slam.campaign import run_campaign
    from slam.kinds.recorded.log import format_odometry_log
    from tests.slam.kinds.recorded.synthetic import synthetic_log

    path = tmp_path_factory.mktemp("log") / "small.txt"
    path.write_text(format_odometry_log(synthetic_log(np.random.default_rng(2), n_poses=60,
                                                      n_landmarks=5)))
    world = log_kind().open_log(path, ["ekf", "srckf"], None)
    return run_campaign(world, workers=1)


def _labelled(fig: Figure) -> list[str]:
    """What is unlabelled in ``fig``: panels with data but no y label; no x label at all."""
    drawn = [ax for ax in fig.axes if ax.get_visible() and ax.axison and ax.has_data()]
    bad = [f"panel {ax.get_title()!r} has no y label" for ax in drawn if not ax.get_ylabel()]
    if drawn and not any(ax.get_xlabel() for ax in drawn):
        bad.append("no x label")
    return bad


@pytest.fixture(scope="module")
def written(request, tmp_path_factory) -> dict[str, tuple[Path, list[str], list[str]]]:
    """Each kind's report folder (the planar one from the session's fixture, the others
    rendered here with a provenance block), the files written and what was unlabelled."""
    out: dict[str, tuple[Path, list[str], list[str]]] = {}
    planar_dir, planar_paths = request.getfixturevalue("planar_written")
    out["planar-slam"] = (planar_dir, [p.name for p in planar_paths], [])
    mp = pytest.MonkeyPatch()
    unlabelled: list[str] = []
    real = Figure.savefig

    def checked(fig, fname, *a, **kw):
        unlabelled.extend(f"{Path(str(fname)).name}: {m}" for m in _labelled(fig))
        return real(fig, fname, *a, **kw)

    mp.setattr(Figure, "savefig", checked)
    try:
        for fixture in ("drone_result", "attitude_result", "recorded_result"):
            result = request.getfixturevalue(fixture)
            source = getattr(result.world, "source", None)
            summary = {**result.summary,
                       "provenance": sample_provenance(result.summary, source)}
            kind = get_kind(result.summary["kind"])
            folder = tmp_path_factory.mktemp("reports") / kind.name
            unlabelled.clear()
            paths = output.write_outputs(replace(result, summary=summary), kind.report, folder)
            out[kind.name] = (folder, [p.name for p in paths], list(unlabelled))
    finally:
        mp.undo()
    return out


@pytest.mark.parametrize("kind", list(FIGURES))
def test_report_has_its_figures_provenance_and_links(kind, written):
    folder, names, unlabelled = written[kind]
    report = get_kind(kind).report
    assert list(report.figures()) == FIGURES[kind]
    assert sorted(n for n in names if n.endswith(".png")) == sorted(FIGURES[kind])
    for name in FIGURES[kind]:
        data = (folder / name).read_bytes()
        assert data.startswith(b"\x89PNG") and 10_000 < len(data) < 600_000, name
    assert not unlabelled, unlabelled
    assert EXTRA[kind] <= set(names)

    summary = strict_loads((folder / "summary.json").read_text(encoding="utf-8"))
    prov = summary["provenance"]
    assert PROVENANCE_KEYS <= set(prov) and prov["version"] and prov["command"].startswith(
        "slam run")
    md = (folder / "report.md").read_text(encoding="utf-8")
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert "## Provenance" in md and "command line" in md and prov["command"] in md
    assert "<h2>Provenance</h2>" in html and "Provenance: navfilters" in html

    links = re.findall(r'href="([^"]+)"', html)
    assert "summary.json" in links and EXTRA[kind] <= set(links)
    for link in links:  # relative names of files written next to the report
        assert "/" not in link and ":" not in link and (folder / link).is_file(), link
    assert not re.search(r'src="(?!data:image/png;base64,)', html)
    assert html.count('src="data:image/png;base64,') == len(FIGURES[kind])


@pytest.mark.parametrize("kind", list(FIGURES))
def test_terminal_table_fits_100_columns(kind, written):
    folder, _, _ = written[kind]
    summary = strict_loads((folder / "summary.json").read_text(encoding="utf-8"))
    text = get_kind(kind).report.text_table(summary)
    assert max(len(line) for line in text.splitlines()) <= 100, text
    assert "srckf" in text


def test_tum_files_say_which_run(written):
    folder, _, _ = written["drone-slam"]
    first = (folder / "srckf.tum").read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# ") and "run 0 of 1" in first
    rows = np.loadtxt(folder / "srckf.tum")
    assert rows.shape[1] == 8
