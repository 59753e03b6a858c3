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
from tests.golden.regenerate import batched_differences as _equal
from tests.golden.regenerate import strip_timings
from tests.small_worlds import small_world

PLANAR = ("ekf", "srckf", "srukf", "srcdkf")
INVARIANT = ("ekf-inv", "srckf-inv")


def _summaries(world, runs: int):
    out = []
    for executor in ("per-run", "batched"):
        result = run_campaign(world, runs=runs, workers=1, executor=executor)
        out.append(strip_timings(result.summary))
    return out


@pytest.mark.parametrize(("sigma", "filters"), [(0.0, PLANAR), (0.3, ("ekf", "srukf")),
                                               (0.3, INVARIANT), (0.3, ("srukf-linv",))])
def test_planar_batched_summary_equals_the_per_run_one(sigma, filters):
    """sigma 0: every run has the same truth, so one batch throughout; 0.3 m: the truths
    differ, landmarks come into view at different epochs, runs end at other steps, and the
    batch is split and regrouped epoch by epoch.  The group-error variants (``-inv``,
    ``-linv``: the state on :class:`~estimators.slam_group.SlamGroup`) batch too."""
    world = small_world(runs=3, filters=filters, vehicle={"initial_sigma_xy_m": sigma})
    per_run, batched = _summaries(world, 3)
    diff = _equal(per_run, batched)
    assert not diff, "\n".join(diff[:10])


def test_what_cannot_share_a_batch_runs_per_run():
    """Nearest-neighbour association, local mode, first-estimates Jacobians and the iterated
    filters run per run (their results are then the per-run ones by construction); the
    group-error variants batch."""
    from slam.kinds.planar.slam import planar_problem
    from slam.mapping import batch

    world = small_world(runs=2, filters=("srckf",))
    logs = [simulate_planar(world, np.random.default_rng(s))
            for s in np.random.SeedSequence(0).spawn(2)]
    calls = []
    real = batch._run_group
    batch._run_group = lambda *a, **k: calls.append(a) or real(*a, **k)
    try:
        problems = [planar_problem(log) for log in logs]
        batch.run_problems(problems, "srckf")
        assert len(calls) == 1
        for kw in ({"association": "nn"}, {"mode": "local"}):
            batch.run_problems(problems, "srckf", **kw)
        batch.run_problems(problems, "iekf", filter_params={})
        batch.run_problems([planar_problem(log, variant="fej") for log in logs], "ekf-fej")
        assert len(calls) == 1
        batch.run_problems([planar_problem(log, variant="inv") for log in logs], "srckf-inv")
        assert len(calls) == 2
    finally:
        batch._run_group = real


@pytest.mark.parametrize("name", ["srckf", "srckf-inv", "ekf-inv"])
def test_a_failing_run_inside_a_batch_ends_alone_with_its_per_run_reason(name):
    world = small_world(runs=3, filters=(name,))
    logs = [simulate_planar(world, np.random.default_rng(s))
            for s in np.random.SeedSequence(4).spawn(3)]
    obs = np.array(logs[1].obs, copy=True)
    obs[len(obs) // 2, 0] = np.nan  # run 1 gets one corrupt range half way
    logs[1] = replace(logs[1], obs=obs)
    batch = run_slam_batch(logs, name, filter_params={})
    alone = [run_slam(log, name, filter_params={}) for log in logs]
    assert batch[1].diverged and batch[1].failure == alone[1].failure
    assert batch[1].failure.startswith("NonFiniteError")
    assert batch[1].epochs_done == alone[1].epochs_done
    for b, a in zip(batch, alone):
        assert b.failure == a.failure
        np.testing.assert_allclose(b.poses, a.poses, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(b.pose_cov, a.pose_cov, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.landmarks, a.landmarks, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(b.landmark_cov, a.landmark_cov, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(b.landmark_ids, a.landmark_ids)
        np.testing.assert_array_equal(b.nis_epoch, a.nis_epoch)
        np.testing.assert_allclose(b.nis, a.nis, rtol=1e-9)


def test_star_sensor_batched_summary_equals_the_per_run_one():
    """Star-sensor attitude: every filter with a batched form over the runs at once (the
    same star epochs), the smoother per run."""
    from tests.small_worlds import short_star_sensor_world

    world = short_star_sensor_world(runs=3)
    per_run, batched = _summaries(world, 3)
    diff = _equal(per_run, batched)
    assert not diff, "\n".join(diff[:10])


def test_drone_batched_summary_equals_the_per_run_one():
    """The drone: the prediction is built along each run's own mean (one model per run of
    the batch), the landmarks come into view at the same epochs (the same truth)."""
    from slam.registry import world_from_dict
    from tests.small_worlds import small_drone_doc

    world = world_from_dict(small_drone_doc(runs=3), name="small-drone")
    per_run, batched = _summaries(world, 3)
    diff = _equal(per_run, batched)
    assert not diff, "\n".join(diff[:10])
