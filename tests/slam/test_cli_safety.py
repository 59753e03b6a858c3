"""The command line's error boundary and ``--out`` safety (:mod:`slam.cli`,
:mod:`slam.render.output`): bad input found during a run still exits 2 with one clean line
and writes nothing; ``--out`` never deletes what slam did not write, never replaces
another campaign silently, is checked before any run; errors cross the worker pool."""

from __future__ import annotations

import json
import os
import pickle
import subprocess

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import slam.campaign
from slam import cli
from slam.kinds.recorded.log import LogFormatError
from slam.render.output import MARKER
from tests.golden.regenerate import strip_timings
from tests.slam.test_cli import SMALL_WORLD, write_world
from tests.small_worlds import small_world
from worlds import WorldError

FAST = ["--runs", "1", "--workers", "1", "--no-plots", "--filters", "ekf"]


def _run(*args: str):
    return CliRunner().invoke(cli.main, ["run", *map(str, args)])


def _no_campaign(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("the campaign ran although the output was refused")

    monkeypatch.setattr(slam.campaign, "run_campaign", refuse)


def _one_error_line(res) -> str:
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error: "), res.output
    return lines[0]


def test_a_foreign_folder_is_refused_before_running_and_kept(tmp_path, monkeypatch):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "precious.txt").write_text("keep me\n")
    _no_campaign(monkeypatch)
    line = _one_error_line(_run(write_world(tmp_path), "--out", out, *FAST))
    assert "--out" in line and "mine" in line and MARKER in line
    assert [p.name for p in out.iterdir()] == ["precious.txt"]
    assert (out / "precious.txt").read_text() == "keep me\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "small.toml"]


def test_the_current_folder_and_dangling_links_are_refused(tmp_path, monkeypatch):
    world = write_world(tmp_path)
    _no_campaign(monkeypatch)
    monkeypatch.chdir(tmp_path)
    assert "current folder" in _one_error_line(_run(world, "--out", ".", *FAST))
    (tmp_path / "link").symlink_to(tmp_path / "missing")
    assert "symbolic link" in _one_error_line(_run(world, "--out", "link", *FAST))
    (tmp_path / "file").write_text("x")
    assert "not a folder" in _one_error_line(_run(world, "--out", "file", *FAST))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "link", "small.toml"]


def test_an_earlier_output_is_replaced_and_named(tmp_path):
    world, out = write_world(tmp_path), tmp_path / "o"
    assert _run(world, "--out", out, *FAST).exit_code == 0
    assert json.loads((out / MARKER).read_text())["campaign"]["seed"] == 5
    res = _run(world, "--out", out, "--seed", "3", *FAST)
    assert res.exit_code == 0, res.output
    assert "replaced the earlier results" in res.output and "seed 5" in res.output
    assert json.loads((out / "summary.json").read_text())["seed"] == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "small.toml"]
    (out / "notes.txt").write_text("mine")  # added by the user since: not slam's to delete
    assert "notes.txt" in _one_error_line(_run(world, "--out", out, *FAST))
    assert (out / "notes.txt").read_text() == "mine"


def test_the_default_folder_names_the_campaign(tmp_path, monkeypatch):
    world = write_world(tmp_path, name="..toml")  # a world called "." must not escape out/
    monkeypatch.chdir(tmp_path)
    res = _run(world, *FAST)
    assert res.exit_code == 0, res.output
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["world-runs1-ekf"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["..toml", "out"]


def test_stale_temp_folders_of_killed_runs_are_removed(tmp_path):
    dead = subprocess.Popen(["true"])
    dead.wait()
    ours, foreign = tmp_path / f".o.tmp-{dead.pid}-abc", tmp_path / f".o.tmp-{dead.pid}-xyz"
    for folder in (ours, foreign):
        folder.mkdir()
        (folder / "summary.json").write_text("{}")
    (ours / MARKER).write_text("{}")
    assert _run(write_world(tmp_path), "--out", tmp_path / "o", *FAST).exit_code == 0
    assert not ours.exists() and (foreign / "summary.json").exists()


def test_bad_input_found_during_a_run_exits_2_and_writes_nothing(tmp_path, monkeypatch):
    text = SMALL_WORLD.replace("[[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]",
                               "[[0.5, 0.0], [0.0, 0.5]]")  # all within reach of the start
    monkeypatch.chdir(tmp_path)
    line = _one_error_line(_run(write_world(tmp_path, text), *FAST))
    assert "small.toml" in line and "[map] waypoints" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.toml"]


def test_error_lines_escape_control_characters_and_cut_long_tokens(tmp_path):
    text = SMALL_WORLD.replace("[vehicle]", '[vehicle]\n"evil\u202ekey\\nx" = 1')
    line = _one_error_line(_run(write_world(tmp_path, text), *FAST))
    assert "\u202e" not in line and "\\u202e" in line and "\\x0a" in line
    cleaned = cli.clean_message("a " + "7" * 5000 + " b\x1b[31m")
    assert len(cleaned) < 250 and "[5000 characters]" in cleaned and "\x1b" not in cleaned


def test_errors_cross_the_worker_pool_intact():
    err = WorldError("w.toml", "map.waypoints", "not reached", [1.0, 2.0])
    for e in (err, WorldError("w.toml", None, "bad"), LogFormatError("l.txt", 3, "bad")):
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is type(e) and str(back) == str(e)
    unreachable = small_world(waypoints=[[0.0, 3.0], [30.0, 30.0]], runs=2)  # in the circle
    with pytest.raises(WorldError, match="did not reach waypoint 0"):
        slam.campaign.run_campaign(unreachable, workers=2)


def test_same_seed_same_summary_on_any_executor(tmp_path):
    world = write_world(tmp_path)
    one, two = tmp_path / "one", tmp_path / "two"
    for out, workers in ((one, "1"), (two, "2")):
        res = _run(world, "--out", out, "--runs", "2", "--workers", workers, "--no-plots",
                   "--filters", "ekf")
        assert res.exit_code == 0, res.output
    a, b = (json.loads((d / "summary.json").read_text()) for d in (one, two))
    assert strip_timings(a) == strip_timings(b) and a != strip_timings(a)
    assert sorted(os.listdir(one)) == sorted(os.listdir(two))


@given(st.text(st.characters(), max_size=3000))  # characters(): no per-checkout codec table
@settings(max_examples=200, deadline=None, database=None)
def test_any_message_becomes_one_printable_bounded_line(text):
    out = cli.clean_message(text)
    assert out.isprintable() and len(out) <= 2040
    assert all(len(tok) <= 170 for tok in out.split(" "))
