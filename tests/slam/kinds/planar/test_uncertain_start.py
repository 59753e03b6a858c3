"""Runs of different lengths: with an uncertain true start each run's vehicle reaches the
waypoints at other times, so the runs have different epoch counts; the summary and the
figures' Monte Carlo envelopes pad the shorter ones (this raised a ValueError before)."""

from __future__ import annotations

import numpy as np

from slam.campaign import run_campaign
from slam.render.plotting import envelope_and_run0
from slam.render.series import n_epochs
from tests.small_worlds import small_world


def test_runs_of_different_lengths_are_summarised_and_drawn():
    world = small_world(runs=3, filters=("ekf",), vehicle={"initial_sigma_xy_m": 0.5})
    result = run_campaign(world, runs=3, workers=1, executor="per-run")
    lengths = {len(o.scores["ekf"].err) for o in result.outcomes}
    assert len(lengths) > 1, "the runs should differ in length for this test to mean anything"
    entry = result.summary["filters"]["ekf"]
    assert np.isfinite(entry["pos_rmse_m"]) and np.isfinite(entry["anees"])
    env, shown = envelope_and_run0(result, "ekf", lambda s: s.err[:, 0], lambda s: s.sigma[:, 0])
    assert env[0].shape == (n_epochs(result),) and shown[0].shape == (n_epochs(result),)
