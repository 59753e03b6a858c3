"""``slam run --log FILE.csv|kitti --holdout K --outage S:L`` from the command line: a run
writes its report; bad input is one line naming the file / option, exit code 2."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from slam import cli
from slam.kinds.ins_log.synthetic import write_log


def _run(*args):
    return CliRunner().invoke(cli.main, ["run", *map(str, args)])


def test_a_csv_log_runs_with_holdout_and_outage(tmp_path):
    log = write_log(tmp_path, duration=75.0)
    out = tmp_path / "out"
    r = _run("--log", log, "--holdout", 5, "--outage", "30:10", "--filters", "ekf",
             "--no-plots", "--out", out)
    assert r.exit_code == 0, r.output
    assert "held-out" in r.output and "drift 30+10 s" in r.output
    s = json.loads((out / "summary.json").read_text())
    assert s["kind"] == "ins-log" and s["holdout"] == 5 and s["outages"] == [[30.0, 10.0]]
    assert set(s["reference"]) == {"gtsam-online", "gtsam"}


@pytest.mark.parametrize(("args", "match"), [
    (["--log", "{dir}/missing.csv"], "missing.csv: cannot be read"),
    (["--log", "{log}", "--holdout", "0"], "--holdout 0: must be in [2, 1000]"),
    (["--log", "{log}", "--outage", "3"], "--outage '3': START:LENGTH"),
    (["--log", "{log}", "--runs", "2"], "--runs does not apply to --log"),
    (["--log", "{log}", "--filters", "ekf,pf"], "unknown filter pf"),
    (["bailey", "--holdout", "5"], "--holdout applies to an IMU + GNSS log only"),
])
def test_bad_input_is_one_line_and_exit_code_2(tmp_path, args, match):
    log = write_log(tmp_path, duration=10.0)
    argv = [a.format(dir=tmp_path, log=log) for a in args]
    r = _run(*argv, "--no-plots", "--out", tmp_path / "out")
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and match in lines[0]
