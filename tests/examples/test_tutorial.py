"""examples/tutorial_beacon.py, the docs' library tutorial, runs and its filters track the
robot: the position error stays well inside the prior's, the NIS is near its 2 dof."""

from __future__ import annotations

import pytest

from examples import tutorial_beacon as tut


@pytest.mark.parametrize("name", ["ekf", "ckf", "srckf"])
def test_the_tutorial_filters_track_the_robot(name: str) -> None:
    rmse, nis = tut.run(name, steps=150, seed=1)
    assert rmse < 1.0
    assert 1.0 < nis < 3.5


def test_the_tutorial_filters_agree() -> None:
    ekf, ckf = tut.run("ekf", steps=150, seed=1), tut.run("ckf", steps=150, seed=1)
    assert abs(ekf[0] - ckf[0]) < 0.1 * ckf[0]
