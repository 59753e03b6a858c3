"""Recorded logs beyond what a run may cost or hold: huge ids (more digits than Python
converts) and a log whose work is over :mod:`worlds.limits` are one-line errors naming the
file (and line), exit 2, nothing written (issue 24)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from slam.cli import main
from slam.kinds.recorded.log import LogFormatError, parse_odometry_log

ODO = "ODOMETRY 0 1 1 0 0 1e-4 0 0 4e-6 0 4e-6\n"


@pytest.mark.parametrize(("text", "line", "message"), [
    (ODO + "ODOMETRY 1 " + "7" * 5000 + " 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2,
     "pose id 77777777777777777777...(5000 characters) is too large (at most 2**56 - 1 = "
     "72057594037927935, GTSAM's key index)"),
    (ODO + "LANDMARK 1 " + "9" * 30 + " 3 4 0.4 0 0.4\n", 2,
     "landmark id 999999999999999999999999999999 is too large (at most 2**56 - 1 = "
     "72057594037927935, GTSAM's key index)"),
    (ODO + "LANDMARK " + "0" * 6000 + "1 7 3 4 0.4 0 0.4\n", None, None),  # = pose 1
    (ODO + "LANDMARK -" + "1" * 5000 + " 7 3 4 0.4 0 0.4\n", 2,
     "pose id -1111111111111111111...(5001 characters) is negative"),
    (ODO.replace("1 0 0 1e-4", "1" * 5000 + " 0 0 1e-4"), 1,
     "motion: '11111111111111111111...(5000 characters)' is not finite"),
])
def test_a_huge_integer_in_a_log_is_a_line_error(text, line, message):
    if message is None:
        assert parse_odometry_log(text, "t.txt").obs_pose.tolist() == [1]
        return
    with pytest.raises(LogFormatError) as err:
        parse_odometry_log(text, "t.txt")
    assert str(err.value) == f"t.txt:{line}: {message}"


def test_a_log_over_a_work_limit_is_refused_by_the_registry(tmp_path):
    """1501 sightings of 5 landmarks from one pose: one update of 3002 measurements
    (limit 3000)."""
    path = tmp_path / "wide.txt"
    path.write_text(ODO + "".join(f"LANDMARK 1 {10 + i % 5} 3 4 0.4 0 0.4\n" for i in range(1501)))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(path), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert res.output == (f"error: --log {path}: the run would need 3,002 measurements in one "
                          "update (1501 sightings from one pose); at most 3,000 are allowed\n")
    assert not out.exists()
