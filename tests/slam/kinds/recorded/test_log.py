"""Recorded logs in GTSAM's planar text format (:mod:`slam.kinds.recorded.log`): round trip,
the parser, errors naming file and line.
"""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.recorded.log import (
    LogFormatError,
    format_odometry_log,
    parse_odometry_log,
    read_odometry_log,
)
from tests.slam.kinds.recorded.synthetic import synthetic_log


def test_round_trip_of_a_synthetic_file(tmp_path):
    log = synthetic_log(np.random.default_rng(0))
    path = tmp_path / "syn.txt"
    path.write_text(format_odometry_log(log))
    back = read_odometry_log(path)
    assert back.equals(log) and back.source == str(path)
    assert format_odometry_log(back) == path.read_text()
    assert back.n_poses == 40 and len(back.landmark_ids) == 6


def test_parser_reads_gtsam_layout_comments_and_blank_lines():
    text = ("# a comment\n\nLANDMARK 0 9 1 2 0.4 0 0.4\n"
            "ODOMETRY 0 1 0.5 0 0.1 0.0001 0 0 4e-06 0 4e-06  # trailing\n"
            "LANDMARK 1 9 3 -4 0.5 0.1 0.3\nODOMETRY 1 4 1 0 0 1 0 0 1 0 1\n")
    log = parse_odometry_log(text, "t.txt")
    assert log.pose_ids.tolist() == [0, 1, 4]
    np.testing.assert_array_equal(log.odometry_cov[0], np.diag([1e-4, 4e-6, 4e-6]))
    np.testing.assert_array_equal(log.obs_cov[1], [[0.5, 0.1], [0.1, 0.3]])
    assert log.obs_pose.tolist() == [0, 1] and log.obs_id.tolist() == [9, 9]
    assert log.obs[1].tolist() == [3.0, -4.0]


GOOD = "ODOMETRY 0 1 1 0 0 1e-4 0 0 4e-6 0 4e-6\n"


@pytest.mark.parametrize("text, line, needle", [
    (GOOD + "LANDMARK 1 7 3 x 0.4 0 0.4\n", 2, "'x' is not a number"),
    (GOOD + "LANDMARK 1 7 3 4 0.4 0\n", 2, "LANDMARK needs 7 fields"),
    (GOOD + "ODOMETRY 1 2 1 0 0 1e-4 0 0 4e-6 0\n", 2, "ODOMETRY needs 11 fields"),
    (GOOD + "ODOMETRY 1 2.5 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "'2.5' is not an integer id"),
    (GOOD + "LANDMARK -1 7 3 4 0.4 0 0.4\n", 2, "pose id -1 is negative"),
    (GOOD + "VERTEX2 1 0 0 0\n", 2, "unknown record 'VERTEX2'"),
    (GOOD + "LANDMARK 1 7 3 4 0.4 0 -0.4\n", 2, "not positive definite"),
    (GOOD + "LANDMARK 1 7 3 nan 0.4 0 0.4\n", 2, "'nan' is not finite"),
    (GOOD + "ODOMETRY 0 2 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "one chain"),
    (GOOD + "ODOMETRY 1 0 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "pose 0 already appeared"),
    (GOOD + "LANDMARK 1 0 3 4 0.4 0 0.4\n", 2, "id 0 is also a pose id"),
    ("\n" + GOOD + "LANDMARK 5 7 3 4 0.4 0 0.4\n", 3, "pose 5 is not on the odometry chain"),
])
def test_malformed_lines_name_file_and_line(text, line, needle):
    with pytest.raises(LogFormatError) as err:
        parse_odometry_log(text, "bad.txt")
    assert str(err.value).startswith(f"bad.txt:{line}: ") and needle in str(err.value)
    assert err.value.line == line


def test_empty_or_missing_file_is_an_error(tmp_path):
    with pytest.raises(LogFormatError, match="no ODOMETRY or LANDMARK"):
        parse_odometry_log("# nothing\n", "e.txt")
    with pytest.raises(LogFormatError, match="file not found"):
        read_odometry_log(tmp_path / "missing.txt")
