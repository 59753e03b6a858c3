"""The log's right-invariant variants (:mod:`slam.kinds.ins_log.invariant`): the prior's
round trip through the group error, the dense and square-root forms of one rule agreeing
in the group, and a variant scored like the other filters on a synthetic turn."""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.ins_log import invariant
from slam.kinds.ins_log.run import alignment, fix_roles, run_once
from slam.kinds.ins_log.synthetic import write_log
from slam.kinds.ins_log.world import open_log


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    return open_log(write_log(tmp_path_factory.mktemp("log")), holdout=5,
                    outages=[(70.0, 10.0)])


def test_the_prior_goes_to_the_group_error_and_back(world):
    a, x0, P0, _ = alignment(world.log, fix_roles(world.log, world.scoring))
    x0 = x0.copy()
    x0[:3] += [120.0, -40.0, 3.0]  # far from the origin: the position rows take [p]x
    S = invariant.group_prior(x0, P0)
    Pxi = S @ S.T
    assert np.max(np.abs(Pxi[0:3, 6:9])) > 1e-3 * np.max(np.abs(Pxi))  # coupled in ξ
    back = invariant.world_covariances(x0[None], Pxi[None])[0]
    np.testing.assert_allclose(back, P0, atol=1e-12 * np.max(P0))


def test_a_variant_runs_in_the_group_and_is_scored_like_the_others(world):
    o = run_once(world, 0, None, ["srckf", "srckf-inv", "ckf-inv"], reference=False)
    for name in ("srckf-inv", "ckf-inv"):
        s = o.scores[name]
        assert not s.diverged, s.failure
        assert s.values["heldout"]["rmse_m"] < 0.05
        assert s.values["outages"][0]["drift_m"] < 2.0
        assert s.values["truth"]["nees_epochs"] == world.log.n_fixes - 1
    inv, dense = (o.scores[n].values["truth"]["rmse_m"] for n in ("srckf-inv", "ckf-inv"))
    assert dense == pytest.approx(inv, rel=1e-9)  # one rule, two forms, the same group
    std = o.scores["srckf"].values["truth"]["rmse_m"]
    assert abs(inv - std) > 1e-6 * std  # not the standard chart's filter


def test_the_variants_are_log_filters():
    from slam.kinds.ins_log.settings import FILTERS

    assert {"srckf-inv", "ukf-inv"} <= set(FILTERS) and "ekf-inv" not in FILTERS
