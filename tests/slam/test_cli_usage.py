"""Every click usage error of the ``slam`` command line is one ``error:`` line with exit
code 2 (:mod:`slam.cli`).  The cases are generated from the commands' own option
declarations, so an option added later is covered: an unknown option on every command,
every value-taking option without its value and with a value of the wrong type."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner

from slam import cli


def _cases() -> list[list[str]]:
    cases = [["nosuchcommand"], ["--bogus"], ["--bogus", "run"]]
    for name, cmd in cli.main.commands.items():
        cases.append([name, "--bogus"])
        for p in cmd.params:
            if not isinstance(p, click.Option) or p.is_flag:
                continue
            opt = p.opts[-1]
            cases.append([name, opt])  # the value missing
            if isinstance(p.type, click.types.IntParamType | click.types.FloatParamType):
                cases.append([name, opt, "not-a-number"])
            if isinstance(p.type, click.Choice):
                cases.append([name, opt, "not-a-choice"])
    return cases


@pytest.mark.parametrize("argv", _cases(), ids=" ".join)
def test_a_usage_error_is_one_line_with_exit_2(argv, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli.main, argv)
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_bare_slam_shows_the_help():
    res = CliRunner().invoke(cli.main, [], prog_name="slam")
    assert res.exit_code == 0 and res.output.startswith("Usage: slam [OPTIONS] COMMAND")


def test_a_filter_whose_settings_the_world_does_not_state_is_refused(tmp_path, monkeypatch):
    """``--filters srukf`` on a world without ``[filters.unscented]`` would run the SRUKF at
    a hidden default: refused in one line (exit 2), nothing written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "w.toml").write_text(
        'kind = "planar-slam"\ndescription = "no unscented settings"\nruns = 1\n'
        '[map]\nbounds_m = [-20.0, 50.0, -20.0, 50.0]\n'
        'landmarks = [[15.0, -6.0], [36.0, 15.0]]\nwaypoints = [[30.0, 0.0], [0.0, 0.0]]\n'
        '[vehicle]\nstart_xy_m = [0.0, 0.0]\nstart_heading_deg = 0.0\n'
        '[filters]\nnames = ["ekf"]\n', encoding="utf-8")
    res = CliRunner().invoke(cli.main, ["run", "w.toml", "--filters", "ekf,srukf",
                                        "--out", "out", "--no-plots"])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert lines == ["error: --filters: srukf need(s) [filters.unscented] settings, which "
                     "w.toml does not state"], res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.toml"]
