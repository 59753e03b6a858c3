"""Joint-mode planar SLAM with the structured steps (:mod:`estimators.structured`: the car
model's static map, the range-bearing model's rows read) gives the dense steps' results to
1e-9 relative, per run and batched, for every filter that has them."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.structured import FALLBACKS, dense_steps
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import run_slam_batch
from tests.small_worlds import small_world

FILTERS = ("ekf", "srckf", "srukf", "srcdkf", "ekf-fej", "srckf-inv", "ekf-inv")
SETTINGS = {"srukf": {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}, "srcdkf": {"h": 3.0 ** 0.5}}


@pytest.fixture(scope="module")
def logs():
    world = small_world()
    return [simulate_planar(world, np.random.default_rng(s)) for s in (0, 1, 2)]


def _rel(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and np.array_equal(np.isnan(a), np.isnan(b))
    ok = ~np.isnan(b)
    return float(np.max(np.abs(a[ok] - b[ok])) / max(np.max(np.abs(b[ok])), 1e-300))


@pytest.mark.parametrize("name", FILTERS)
@pytest.mark.parametrize("batched", [False, True])
def test_structured_joint_runs_equal_dense(logs, name, batched):
    kw = dict(filter_params=SETTINGS.get(name.partition("-")[0]), batched=batched)
    FALLBACKS.clear()
    out = run_slam_batch(logs, name, **kw)
    with dense_steps():
        ref = run_slam_batch(logs, name, **kw)
    assert not FALLBACKS
    for r, d in zip(out, ref):
        assert (r.diverged, r.failure) == (d.diverged, d.failure)
        assert np.array_equal(r.landmark_ids, d.landmark_ids)
        for a, b in ((r.poses, d.poses), (r.pose_cov, d.pose_cov), (r.landmarks, d.landmarks),
                     (r.landmark_cov, d.landmark_cov), (r.nis, d.nis)):
            assert _rel(a, b) < 1e-9
