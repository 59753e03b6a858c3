"""What the command line shows besides the tables: ``slam worlds`` within 100 columns,
"did you mean" for misspelt names, the worker count as used and the progress bar's total
and ETA."""

from __future__ import annotations

import io
import json
import re

from click.testing import CliRunner

from slam import cli
from slam.registry import list_worlds, load_world, world_from_dict
from slam.terminal import WIDTH, expected_epochs, progress_bar, world_lines
from tests.slam.test_cli import write_world
from worlds import WorldError


def test_slam_worlds_fits_100_columns_and_lists_every_world():
    res = CliRunner().invoke(cli.main, ["worlds"])
    assert res.exit_code == 0
    lines = res.output.splitlines()
    assert max(len(line) for line in lines) <= WIDTH
    starts = [line.split()[0] for line in lines if not line.startswith(" ")]
    assert starts == [name for name, _, _ in list_worlds()]


def test_a_long_description_wraps_under_itself():
    rows = [("a", "k", "word " * 40), ("bb", "kind", "short")]
    lines = world_lines(rows, width=40)
    assert all(len(line) <= 40 for line in lines)
    assert lines[0].startswith("a   k     word") and lines[1].startswith(" " * 10 + "word")
    assert lines[-1] == "bb  kind  short"


def test_a_misspelt_world_name_gets_a_suggestion():
    res = CliRunner().invoke(cli.main, ["run", "baily"])
    assert res.exit_code == 2
    assert "no bundled world of that name (did you mean 'bailey'?)" in res.output


def test_a_misspelt_filter_name_gets_a_suggestion(tmp_path):
    res = CliRunner().invoke(cli.main, ["run", str(write_world(tmp_path)), "--filters",
                                        "ekf,srckff", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert re.search(r"unknown filter srckff \(did you mean 'srckf'", res.output)
    assert not (tmp_path / "o").exists()


def test_a_misspelt_world_key_gets_a_suggestion():
    data = {"kind": "planar-slam", "description": "x", "runs": 1, "sede": 3}
    try:
        world_from_dict(data, source="w.toml")
    except WorldError as exc:
        assert str(exc).startswith("w.toml: sede: unknown key (did you mean 'seed'?)")
    else:
        raise AssertionError("an unknown key was accepted")


def test_the_worker_count_is_reported_as_used(tmp_path):
    """64 workers asked for a 2-run campaign: the per-run path uses 2, the batched one
    (one chunk of runs) 1; the terminal and the provenance say so."""
    world = write_world(tmp_path)
    for executor, used, word in (("per-run", 2, "workers"), ("batched", 1, "worker")):
        out = tmp_path / executor
        res = CliRunner().invoke(cli.main, ["run", str(world), "--workers", "64", "--no-plots",
                                            "--executor", executor, "--out", str(out)])
        assert res.exit_code == 0, res.output
        assert f" on {used} local {word}; results in" in res.output
        assert json.loads((out / "summary.json").read_text())["provenance"]["workers"] == used


def test_the_progress_bar_has_a_total_and_an_eta():
    w = load_world("star-sensor")  # 600 s at 2 Hz: 1200 epochs after the first
    campaign = {"runs": 3, "filters": ["ekf", "srckf"]}
    assert expected_epochs(w, campaign) == 3 * 2 * 1200
    text = io.StringIO()
    with progress_bar(w, campaign, file=text, disable=False) as (bar, runs_done, epochs):
        epochs(1000)
        assert (bar.n, bar.total) == (1000, 7200)
        epochs(8000)  # more than estimated: the total is raised, never passed
        assert bar.total > 8000
        runs_done(3)
        assert bar.n == bar.total
    shown = text.getvalue()
    assert "1000/7200 epochs" in shown and "runs 0/3" in shown and "runs 3/3" in shown
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d", shown)  # elapsed < remaining
