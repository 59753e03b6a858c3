"""The ``slam`` command line (:mod:`slam.cli`) end to end on small worlds."""

from __future__ import annotations

import hashlib
import json
import re

import pytest
from click.testing import CliRunner

from slam import cli

SMALL_WORLD = """
kind = "planar-slam"
description = "CLI test world: 30 m square, 4 landmarks"
runs = 2
seed = 5

[map]
bounds_m = [-20.0, 50.0, -20.0, 50.0]
landmarks = [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]]
waypoints = [[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]

[vehicle]
loops = 1
start_xy_m = [0.0, 0.0]
start_heading_deg = 0.0

[filters]
names = ["ekf", "srckf"]

[filters.central_difference]  # for --filters srcdkf
h = 1.7320508075688772
"""


def write_world(tmp_path, text=SMALL_WORLD, name="small.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_run_small_world_end_to_end(tmp_path):
    """The world's own runs, seed and filters; the report without figures (the planar
    figures are drawn in ``test_reports.py``, and the command line draws a kind's figures
    in the fixed-wing and alignment campaign tests)."""
    world = write_world(tmp_path)
    out = tmp_path / "out"
    res = CliRunner().invoke(cli.main, ["run", str(world), "--out", str(out), "--workers", "1",
                                        "--no-plots"])
    assert res.exit_code == 0, res.output
    for row in ("ekf", "srckf", "odometry", "gtsam"):
        assert re.search(rf"^{row}\s", res.output, re.M)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["world"] == "small" and summary["runs"] == 2 and summary["seed"] == 5
    assert set(summary["filters"]) == {"ekf", "srckf"}
    prov = summary["provenance"]
    assert (prov["world_file"], prov["seed"], prov["runs"], prov["workers"]) == (
        str(world), 5, 2, 1)
    assert prov["world_sha256"] == hashlib.sha256(world.read_bytes()).hexdigest()
    assert "Provenance" in (out / "report.md").read_text()
    for f in ("report.md", "report.html", "srckf.tum", "truth.tum"):
        assert (out / f).stat().st_size > 0
    assert not list(out.glob("*.png"))


def test_filters_and_runs_options_override_the_world(tmp_path):
    world = write_world(tmp_path)
    out = tmp_path / "o"
    res = CliRunner().invoke(cli.main, ["run", str(world), "--filters", "srcdkf", "--runs",
                                        "1", "--seed", "3", "--out", str(out), "--workers",
                                        "1", "--no-plots"])
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary["filters"]) == ["srcdkf"] and summary["runs"] == 1
    assert summary["seed"] == 3 and not (out / "map.png").exists()


BAD_WORLDS = [
    ("runs = 2", "runs = 0", "runs"),
    ("loops = 1", "loops = -1", "[vehicle] loops"),
    ('names = ["ekf", "srckf"]', 'names = ["ekf", "kalman9000"]', "[filters] names"),
    ("[vehicle]", "[vehicle]\nspeed_mps = -3.0", "[vehicle] speed_mps"),
    ("[vehicle]", "[vehicle]\nwheel_base = 4.0", "[vehicle] wheel_base"),
    ("[30.0, 30.0], [0.0, 30.0]", "[30.0, 300.0], [0.0, 30.0]", "[map] waypoints"),
    ("bounds_m = [-20.0, 50.0, -20.0, 50.0]", "bounds_m = 3", "[map] bounds_m"),
    ("start_heading_deg = 0.0", 'start_heading_deg = "east"', "[vehicle] start_heading_deg"),
    ('kind = "planar-slam"', 'kind = "planar-slam', "small.toml"),
]


@pytest.mark.parametrize(("old", "new", "key"), BAD_WORLDS)
def test_malformed_world_exits_2_naming_the_key_and_writes_nothing(tmp_path, old, new, key):
    assert old in SMALL_WORLD
    world = write_world(tmp_path, SMALL_WORLD.replace(old, new, 1))
    out = tmp_path / "out"
    res = CliRunner().invoke(cli.main, ["run", str(world), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "small.toml" in res.output and key in res.output
    assert not out.exists()


@pytest.mark.parametrize("args", [["--filters", "ekf,nope"], ["--runs", "0"],
                                  ["--seed", "-1"], ["--workers", "0"], ["nosuchworld"]])
def test_bad_options_exit_2(tmp_path, args):
    world = write_world(tmp_path)
    argv = ["run"] + ([] if args == ["nosuchworld"] else [str(world)]) + args
    res = CliRunner().invoke(cli.main, argv + ["--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert "error:" in res.output and not (tmp_path / "o").exists()


def test_interrupted_run_leaves_no_partial_output(tmp_path, monkeypatch):
    world = write_world(tmp_path)
    out = tmp_path / "out"
    import slam.campaign

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(slam.campaign, "run_campaign", interrupted)
    res = CliRunner().invoke(cli.main, ["run", str(world), "--out", str(out)])
    assert res.exit_code != 0
    assert not out.exists()
    assert not list(tmp_path.glob(".out*"))


def test_worlds_lists_the_bundled_worlds():
    res = CliRunner().invoke(cli.main, ["worlds"])
    assert res.exit_code == 0
    for name in ("bailey", "bailey-sparse", "webmap", "densemap"):
        assert re.search(rf"^{name}\s+planar-slam", res.output, re.M)


def test_filters_are_checked_against_the_worlds_kind(tmp_path):
    """``--filters`` takes the filters of the world's kind: the H∞ filters run on the
    spinning kind and are refused, with the kind's list, on a planar world."""
    from slam.registry import get_kind

    assert cli._parse_filters("srchinf,uthinf", (), get_kind("spinning").filters) == [
        "srchinf", "uthinf"]
    res = CliRunner().invoke(cli.main, ["run", str(write_world(tmp_path)), "--filters",
                                        "srchinf", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    line = res.output.strip().splitlines()[-1]
    assert "unknown filter srchinf" in line and "hommukf" in line and "uthinf" not in line
    assert not (tmp_path / "o").exists()


def test_version_names_the_package_python_and_libraries():
    res = CliRunner().invoke(cli.main, ["--version"])
    assert res.exit_code == 0, res.output
    first, libs = res.output.strip().splitlines()
    assert first.startswith("navfilters ") and "Python" in first
    assert "numpy" in libs and "gtsam" in libs
