"""slam.testing's checks: each one passes on a good campaign and fails with a message that
names the filter, the run, the epoch and the figure (made-up runs with known faults); the
tiny worlds are package data, not bundled worlds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from slam import testing
from slam.registry import list_worlds
from slam.results import CampaignResult, RunOutcome
from slam.scoring import anees_band


@dataclass(frozen=True)
class Fake:
    err: np.ndarray
    nees: np.ndarray
    nis: np.ndarray
    nis_dof: int = 2
    diverged: bool = False
    failure: str | None = None


def _result(scores: list[Fake], summary: dict) -> CampaignResult:
    times = np.arange(len(scores[0].err)) * 0.5
    outcomes = [RunOutcome(r, {"mine": s}, times=times if r == 0 else None)
                for r, s in enumerate(scores)]
    return CampaignResult(None, {"world": "fake", "runs": len(scores), **summary}, outcomes)


def test_no_divergence_names_the_run_epoch_and_reason():
    err = np.zeros((6, 3))
    broken = err.copy()
    broken[4:] = np.nan
    res = _result([Fake(err, np.ones(6), np.ones(6)),
                   Fake(broken, np.ones(6), np.ones(6), diverged=True, failure="LinAlgError: x")],
                  {"filters": {"mine": {}}})
    with pytest.raises(AssertionError, match=r"run 1: mine diverged at epoch 4 \(t = 2\): "
                                             r"LinAlgError: x"):
        testing.no_divergence(res)
    testing.no_divergence(_result([Fake(err, np.ones(6), np.ones(6))], {"filters": {"mine": {}}}))


def test_nees_and_nis_checks_name_the_first_epoch_and_the_worst_run():
    lo, hi = anees_band(2, 3)
    nees = np.full(8, 3.0)
    big = nees.copy()
    big[5:] = 60.0  # run 1 over-confident from epoch 5
    entry = {"anees": float(np.mean((nees + big) / 2) / 3), "anees_bounds_95": [lo, hi],
             "anees_steps_inside_95": 5 / 8, "runs_scored": 2}
    res = _result([Fake(np.zeros((8, 3)), nees, np.ones(8)),
                   Fake(np.zeros((8, 3)), big, np.full(8, 9.0))], {"filters": {"mine": entry}})
    with pytest.raises(AssertionError) as err:
        testing.nees_in_band(res)
    text = str(err.value)
    assert "mine: ANEES" in text and "62 % of epochs inside (need 90 %)" in text
    assert "first epoch outside: epoch 5 (t = 2.5)" in text and "largest: run 1" in text
    assert "consistency / NEES figure" in text
    with pytest.raises(AssertionError, match=r"mine: NIS/dof 2.5, .* largest: run 1 \(NIS/dof "
                                             r"4.5\)"):
        testing.nis_in_band(res)


def test_the_checks_pass_on_a_tiny_world_with_the_built_in_filters():
    result = testing.run("tiny-planar", ["ekf", "srckf"], runs=4)
    testing.no_divergence(result)
    testing.consistent(result)
    testing.error_within(result, factor=3.0)
    with pytest.raises(AssertionError, match=r"ekf: pos_rmse_m = .* the smoother's"):
        testing.error_within(result, factor=1.0)  # a filter is no better than the smoother


def test_tiny_worlds_are_package_data_not_bundled_worlds():
    bundled = {name for name, _, _ in list_worlds()}
    assert not bundled & set(testing.tiny_worlds())
    for name in testing.tiny_worlds():
        w = testing.tiny_world(name)
        assert w.runs <= 4 and "unit tests (slam.testing)" in w.description
