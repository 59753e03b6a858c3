"""The campaign runner (:mod:`slam.campaign`): seeds, tasks, and executors that give the
same bits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from slam.campaign import campaign_tasks, dask_mapper, run_campaign, run_seeds
from slam.render.tables import summary_json
from slam.results import REFERENCE
from tests.small_worlds import small_world


def _strip_timings(obj):
    """Drop wall-clock fields: the only keys that may differ between executors."""
    if isinstance(obj, dict):
        return {k: _strip_timings(v) for k, v in obj.items() if not k.startswith("time")}
    return obj


def test_run_seeds_are_reproducible_and_independent():
    a, b = run_seeds(7, 4), run_seeds(7, 4)
    draws = [np.random.default_rng(s).integers(0, 2**63, 4) for s in a]
    assert all(np.array_equal(d, np.random.default_rng(s).integers(0, 2**63, 4))
               for d, s in zip(draws, b))
    assert len({tuple(d) for d in draws}) == 4
    # the first runs of a longer campaign are the same runs
    assert [s.entropy for s in run_seeds(7, 6)[:4]] == [s.entropy for s in a]
    assert [s.spawn_key for s in run_seeds(7, 6)[:4]] == [s.spawn_key for s in a]


def test_campaign_tasks_keep_tracks_of_run_zero_only():
    world = object()
    tasks = campaign_tasks(world, ("ekf", "srckf"), 3, 5)
    assert [t[1] for t in tasks] == [0, 1, 2]
    assert [t[4] for t in tasks] == [True, False, False]
    assert all(t[0] is world and t[3] == ["ekf", "srckf"] for t in tasks)


def test_an_unregistered_kind_is_refused():
    @dataclass(frozen=True)
    class Nowhere:
        kind: str = "no-such-kind"

    with pytest.raises(ValueError, match="no-such-kind"):
        run_campaign(Nowhere(), runs=1, seed=0, filters=["ekf"])


@pytest.mark.filterwarnings("ignore:Port .* is already in use:UserWarning")  # another cluster
def test_dask_cluster_matches_a_campaign_in_this_process():
    distributed = pytest.importorskip("dask.distributed")

    world = small_world(runs=2, filters=("ekf", "srckf"))
    local = run_campaign(world, workers=1)  # = the pool's (test_cli_safety: any executor)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        mapper, client = dask_mapper(cluster.scheduler_address)
        try:
            seen = []
            remote = run_campaign(world, mapper=mapper, progress=seen.append)
        finally:
            client.close()
    assert sum(seen) == 2  # runs, reported as their (batched) tasks complete
    assert summary_json(_strip_timings(remote.summary)) == summary_json(
        _strip_timings(local.summary))
    # and more than the summary: every run's per-step errors are bit-identical
    for a, b in zip(local.outcomes, remote.outcomes):
        for name in a.scores:
            assert a.scores[name].err.tobytes() == b.scores[name].err.tobytes()


def test_epoch_progress_counts_every_filter_epoch_on_any_executor():
    """The progress count is the filter epochs actually run: equal in this process and
    across the pool, and it changes nothing in the results."""
    world = small_world(runs=2, filters=("ekf",))  # counting needs no second filter
    counts: dict[int, list[int]] = {1: [], 2: []}
    results = {w: run_campaign(world, workers=w, epochs=counts[w].append) for w in (1, 2)}
    n = counts[1][-1]
    steps = sum(s.steps for o in results[1].outcomes for name, s in o.scores.items()
                if name != REFERENCE)  # the smoother runs no filter loop
    assert n > 0 and counts[2][-1] == n and counts[1] == sorted(counts[1])
    assert n == steps  # the filters' own step counts, odometry dead reckoning included
    plain = run_campaign(world, workers=1)
    assert summary_json(_strip_timings(plain.summary)) == summary_json(
        _strip_timings(results[1].summary))
