"""The batched path (runs as an array axis) against the per-run path: the same summary in
every key but timings to 1e-9 relative, on small campaigns of every kind that has it; and
a run that fails inside a batch ends alone with the per-run reason."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from slam.campaign import run_campaign
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import run_slam, run_slam_batch
from tests.golden.regenerate import differences, strip_timings
from tests.small_worlds import small_world

PLANAR = ("ekf", "srckf", "srukf", "srcdkf")


def _summaries(world, runs: int):
    out = []
    for executor in ("per-run", "batched"):
        result = run_campaign(world, runs=runs, workers=1, executor=executor)
        out.append(strip_timings(result.summary))
    return out


@pytest.mark.parametrize(("sigma", "association"), [(0.0, "known"), (0.3, "known"),
                                                     (0.0, "nn")])
def test_planar_batched_summary_equals_the_per_run_one(sigma, association):
    """sigma 0: every run has the same truth, so one batch throughout; 0.3 m: the truths
    differ, landmarks come into view at different epochs and the batch is split and
    regrouped epoch by epoch; nn: per run (the association depends on the estimates)."""
    world = small_world(runs=4, filters=PLANAR, filter_options={"association": association},
                        vehicle={"initial_sigma_xy_m": sigma})
    per_run, batched = _summaries(world, 4)
    diff = differences(per_run, batched)
    assert not diff, "\n".join(diff[:10])


def test_a_failing_run_inside_a_batch_ends_alone_with_its_per_run_reason():
    world = small_world(runs=3, filters=("srckf",))
    logs = [simulate_planar(world, np.random.default_rng(s))
            for s in np.random.SeedSequence(4).spawn(3)]
    obs = np.array(logs[1].obs, copy=True)
    obs[len(obs) // 2, 0] = np.nan  # run 1 gets one corrupt range half way
    logs[1] = replace(logs[1], obs=obs)
    batch = run_slam_batch(logs, "srckf", filter_params={})
    alone = [run_slam(log, "srckf", filter_params={}) for log in logs]
    assert batch[1].diverged and batch[1].failure == alone[1].failure
    assert batch[1].failure.startswith("NonFiniteError")
    assert batch[1].epochs_done == alone[1].epochs_done
    for b, a in zip(batch, alone):
        assert b.failure == a.failure
        np.testing.assert_allclose(b.poses, a.poses, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(b.landmarks, a.landmarks, rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(b.landmark_ids, a.landmark_ids)
        np.testing.assert_array_equal(b.nis_epoch, a.nis_epoch)
        np.testing.assert_allclose(b.nis, a.nis, rtol=1e-9)
