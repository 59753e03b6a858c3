"""The IMU + GNSS readers under the fuzz families (:mod:`benchmarks.fuzz.insmutate`), in
this process: every mutated CSV / sidecar / KITTI folder is either read or refused with a
:class:`~slam.kinds.recorded.log.LogFormatError` (file:line: message) - never another
exception.  ``python -m benchmarks.fuzz.ins`` runs the same cases through the CLI."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from benchmarks.fuzz.insmutate import INS_FAMILIES, ins_cases
from slam.kinds.recorded.log import LogFormatError
from slam.registry import open_log


@pytest.fixture(scope="module")
def cases():
    return ins_cases(3 * 2 * len(INS_FAMILIES), seed=7)


def test_every_family_makes_cases(cases):
    assert {c.family for c in cases} == set(INS_FAMILIES)


def test_mutated_logs_are_read_or_refused_never_a_traceback(cases, tmp_path):
    refused = 0
    for k, case in enumerate(cases):
        folder = tmp_path / str(k)
        folder.mkdir()
        for rel, data in case.extra:
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / rel).write_bytes(data)
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            open_log(Path(case.target), None, None)
        except LogFormatError as exc:
            refused += 1
            assert str(exc).count("\n") == 0, case.name
        except Exception as exc:  # noqa: BLE001 - the failure this test looks for
            pytest.fail(f"{case.family} {case.name}: {type(exc).__name__}: {exc}")
        finally:
            os.chdir(cwd)
    assert refused > len(cases) // 2
