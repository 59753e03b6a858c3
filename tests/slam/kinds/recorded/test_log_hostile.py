"""Hostile log text (:mod:`slam.kinds.recorded.log`): every token either parses or raises a
:class:`LogFormatError` naming file and line - no other exception, no "1_000" or
non-ASCII digits taken for numbers - and the values a filter or GTSAM cannot use are
refused with the allowed range."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.kinds.recorded.log import LogFormatError, parse_odometry_log

ODO = "ODOMETRY 0 1 {} 0 0 1e-4 0 0 4e-6 0 4e-6\n"
LM = "LANDMARK 1 7 {} {} 0.4 0 0.4\n"


@given(st.text(st.characters(), max_size=40))  # characters(): no per-checkout codec table
@settings(max_examples=300, deadline=None, database=None)
def test_any_token_parses_or_is_a_named_error(tok):
    for text in (ODO.format(tok), ODO.format(0.5) + LM.format(tok, 1.0),
                 ODO.format(0.5).replace("0 1", f"0 {tok}", 1)):
        try:
            parse_odometry_log(text, "t.txt")
        except LogFormatError as exc:
            assert str(exc).startswith("t.txt")


@pytest.mark.parametrize(("text", "needle"), [
    (ODO.format("1_000"), "'1_000' is not a number"),
    (ODO.format("\u0661\u0662\u0663"), "is not a number"),
    (ODO.format("1e300"), "beyond"),
    (ODO.format(0.5).replace("1e-4", "1e-300"), "eigenvalues"),
    (ODO.format(0.5).replace("1e-4", "1e20").replace("4e-6 0 4e-6", "4e-6 0 1e-20"),
     "beyond"),
    (ODO.format(0.5).replace("0 1", f"0 {2**63}", 1), "too large"),
    (ODO.format(0.5).replace("0 1", f"0 {2**56}", 1), "too large"),
    (ODO.format(0.5) + LM.format(0, 0), "at the robot"),
])
def test_values_no_filter_or_smoother_can_use_are_refused(text, needle):
    with pytest.raises(LogFormatError, match=needle):
        parse_odometry_log(text, "t.txt")


def test_repeated_sightings_at_one_pose_run_in_every_mode():
    from slam.kinds.recorded.models import run_recorded

    text = (ODO.format(1.0) + LM.format(3.0, 1.0) * 6 + "ODOMETRY 1 2 1 0 0 1e-4 0 0 4e-6 0 "
            "4e-6\n" + "LANDMARK 2 7 2 1 0.4 0 0.4\n" * 6)
    log = parse_odometry_log(text, "t.txt")
    for mode in ("local", "joint"):
        for name in ("ekf", "srckf", "srukf", "srcdkf"):
            r = run_recorded(log, name, mode=mode)
            assert not r.diverged and r.landmark_ids.tolist() == [7], (mode, name, r.failure)
