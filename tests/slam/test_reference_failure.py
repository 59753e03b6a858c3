"""A smoother that fails numerically (GTSAM's ``IndeterminantLinearSystemException`` is a
``RuntimeError`` in Python) is reported like a filter's divergence: the reference is
marked failed on that run with its reason and the filters' results are kept, in every
kind (:mod:`slam.failures`)."""

from __future__ import annotations

import numpy as np
import pytest

from slam.campaign import run_campaign
from slam.failures import reason, run_reference
from slam.kinds.recorded.world import open_log
from slam.results import REFERENCE
from tests.slam.kinds.recorded.synthetic import synthetic_log
from tests.small_worlds import short_star_sensor_world, small_drone_world, small_world

INDETERMINATE = ("\nIndeterminant linear system detected while working near variable\n"
                 "7782220156096217088 (Symbol: l0).\n\nThus, the system is underdetermined.")


def _fail(*args, **kwargs):
    raise RuntimeError(INDETERMINATE)


def test_run_reference_returns_the_reason_and_lets_bugs_through():
    assert run_reference(lambda x: x + 1, 1) == (2, None)
    assert run_reference(_fail) == (None, "RuntimeError: Indeterminant linear system detected "
                                          "while working near variable 7782220156096217088 "
                                          "(Symbol: l0).")
    for bug in (RecursionError, NotImplementedError, KeyError):
        def raise_bug(bug=bug):
            raise bug("a bug")

        with pytest.raises(bug):
            run_reference(raise_bug)
    assert reason(np.linalg.LinAlgError("x\ny")) == "LinAlgError: x y"


def _ship():
    from tests.slam.kinds.ship.worlds import ship_world

    return ship_world(20.0, runs=1)


def _spinning():
    from tests.slam.kinds.spinning.helpers import tiny_world

    return tiny_world(runs=1)


@pytest.mark.parametrize("kind", ["planar", "drone", "attitude", "ship", "spinning"])
def test_a_failed_smoother_is_a_failed_reference(kind, monkeypatch):
    module, smoother, world = {
        "planar": ("slam.kinds.planar.run", "smooth_planar", lambda: small_world(runs=1)),
        "drone": ("slam.kinds.drone.run", "smooth_drone",
                  lambda: small_drone_world(runs=1, filters={"names": ["ekf"]})),
        "attitude": ("slam.kinds.attitude.run", "smooth_attitude",
                     lambda: short_star_sensor_world(10.0, runs=1)),
        "ship": ("slam.kinds.ship.run", "smooth_ship", _ship),
        "spinning": ("slam.kinds.spinning.run", "smooth", _spinning),
    }[kind]
    monkeypatch.setattr(f"{module}.{smoother}", _fail)
    w = world()
    summary = run_campaign(w, filters=["ekf"], runs=1).summary
    ref = summary["reference"][REFERENCE]
    assert ref["runs_scored"] == 0 and ref["diverged_runs"] == 1
    assert ref["failures"] == [reason(RuntimeError(INDETERMINATE))]
    assert summary["filters"]["ekf"]["runs_scored"] == 1
    assert np.isfinite(summary["filters"]["ekf"]["pos_rmse_m" if kind in ("planar", "drone")
                                                 else "anees"])


def test_a_failed_smoother_leaves_a_recorded_log_unscored(tmp_path, monkeypatch):
    monkeypatch.setattr("slam.kinds.recorded.scoring.smooth_recorded", _fail)
    path = tmp_path / "log.txt"
    from slam.kinds.recorded.log import format_odometry_log

    path.write_text(format_odometry_log(synthetic_log(np.random.default_rng(0), n_poses=20,
                                                      n_landmarks=3)))
    summary = run_campaign(open_log(path, ["ekf"]), filters=["ekf"], runs=1).summary
    assert summary["reference"][REFERENCE] == {"diverged": True,
                                               "failure": reason(RuntimeError(INDETERMINATE))}
    assert summary["filters"]["ekf"]["landmarks_mapped"] == 3
    assert "pose_rmse_to_ref_m" not in summary["filters"]["ekf"]
