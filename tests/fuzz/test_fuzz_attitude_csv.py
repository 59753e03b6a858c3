"""The fuzz harness's families applied to the recorded-attitude CSV reader
(:mod:`benchmarks.fuzz.attitude_csv`): reproducible cases of every family, and every case
through ``slam run --log`` in-process ends in exit 0 or a one-line exit-2 error, never a
traceback (the long-log variants of ``csv-huge`` only through the reader: they run for
seconds when valid)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

import slam.cli
from benchmarks.fuzz.attitude_csv import CSV_FAMILIES, csv_cases, load_csv_lines
from slam.kinds.attitude_log.log import read_attitude_log
from slam.kinds.recorded.log import LogFormatError

N = 7 * len(CSV_FAMILIES)


@pytest.fixture(scope="module")
def cases():
    return csv_cases(N, 3, load_csv_lines(20))


def test_cases_are_reproducible_and_cover_every_family(cases):
    again = csv_cases(N, 3, load_csv_lines(20))
    assert [c.ident for c in cases] == [c.ident for c in again]
    assert {c.family for c in cases} == set(CSV_FAMILIES)


def test_every_case_exits_0_or_2_in_one_line(cases, tmp_path):
    outcomes = {0: 0, 2: 0}
    for i, case in enumerate(cases):
        if case.data is None:
            target = case.target
        else:
            target = tmp_path / f"case{i}.csv"
            target.write_bytes(case.data)
        if case.family == "csv-huge" and "rows" in case.name:
            try:  # a long valid log: the reader alone
                read_attitude_log(target)
            except LogFormatError:
                pass
            continue
        res = CliRunner().invoke(slam.cli.main, ["run", "--log", str(target), "--filters",
                                                 "srckf", "--no-plots", "--out",
                                                 str(tmp_path / f"out{i}")])
        assert res.exit_code in (0, 2), (case.family, case.name, res.output, res.exception)
        if res.exit_code == 2:
            assert res.output.startswith("error: ") and res.output.count("\n") == 1, (
                case.name, res.output)
        outcomes[res.exit_code] += 1
    assert outcomes[2] > N // 2 and outcomes[0] > 0, outcomes  # most mutations are refused
