"""The drone's online row (``isam2``, ``[filters] online`` / ``--online``): iSAM2's state
and pose marginal after every epoch over the smoother's graph."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from slam.campaign import run_campaign, run_seeds
from slam.cli import main
from slam.kinds.drone.models import QUAT
from slam.kinds.drone.online import online_drone
from slam.kinds.drone.reference import smooth_drone
from slam.kinds.drone.simulate import DroneLog, simulate_drone
from slam.kinds.planar.world import ONLINE
from slam.mapping.online_map import ONLINE_MAP_STRIDE
from tests.small_worlds import small_drone_world
from worlds import WorldError


@pytest.fixture(scope="module")
def log() -> DroneLog:
    return simulate_drone(small_drone_world(runs=1), np.random.default_rng(run_seeds(0, 1)[0]))


@pytest.fixture(scope="module")
def row(log):
    return online_drone(log)


def _up_to(log: DroneLog, k: int) -> DroneLog:
    """The log's epochs 0..k and their sightings (the IMU samples after them unused)."""
    m = log.obs_epoch <= k
    return replace(log, steps=log.steps[:k + 1], times=log.times[:k + 1],
                   truth=log.truth[:k + 1], obs_epoch=log.obs_epoch[m], obs_id=log.obs_id[m],
                   obs=log.obs[m])


def test_the_online_row_is_a_full_lm_re_solve_of_the_graph_up_to_each_epoch(log, row):
    """At 6 epochs spread over the flight, the row is the LM optimum of the graph of epochs
    0..k (the smoother of the log cut there, its marginals by the square-root sweep) to
    1 cm / 2e-4 rad, its [δp, δθ] σ that optimum's to 1 % (measured worst: 4.6 mm, 7.5e-5
    rad, 0.33 %, against position σ of 0.03-0.26 m: iSAM2 relinearises only past its
    threshold, every 10 updates)."""
    worst = np.zeros(3)
    for k in np.linspace(5, log.n_epochs - 1, 6).astype(int):
        sub = smooth_drone(_up_to(log, int(k)), schedule="epochs", bias_point="prior",
                           marginal_method="chain")
        rot = QUAT.local(sub.q[-1:], row.q[k:k + 1])[0]
        ratio = np.sqrt(np.diag(row.pose_cov[k]) / np.diag(sub.pose_cov[-1]))
        worst = np.maximum(worst, [np.linalg.norm(sub.p[-1] - row.p[k]), np.linalg.norm(rot),
                                   np.max(np.abs(ratio - 1.0))])
    assert worst[0] < 1e-2 and worst[1] < 2e-4 and worst[2] < 1e-2, worst


def test_the_last_epoch_is_the_final_smoothers(log, row):
    """The same graph (prior-bias preintegration): after the last epoch the row is the
    keyframes smoother's last state to 5 mm, its σ to 2 %."""
    ref = smooth_drone(log)
    assert np.linalg.norm(ref.p[-1] - row.p[-1]) < 5e-3
    ratio = np.sqrt(np.diag(row.pose_cov[-1]) / np.diag(ref.pose_cov[-1]))
    assert np.max(np.abs(ratio - 1.0)) < 2e-2, ratio
    np.testing.assert_array_equal(row.landmark_ids, ref.landmark_ids)
    assert np.max(np.linalg.norm(row.landmarks - ref.landmarks, axis=1)) < 1e-2
    assert row.name == ONLINE and row.time_s > 0 and row.steps == log.n_epochs - 1
    # the map over time: every tenth epoch and the last; at the last, the final map's NEES
    m = row.map_series
    sampled = np.unique(np.r_[np.arange(0, log.n_epochs, ONLINE_MAP_STRIDE), log.n_epochs - 1])
    assert m.dof == 3 and np.array_equal(np.flatnonzero(m.nees_count > 0),
                                         sampled[m.nees_count[sampled] > 0])
    assert np.all(np.isnan(np.delete(m.nees, sampled)))
    cov = ref.landmark_cov
    err = ref.landmarks - log.landmarks[ref.landmark_ids]
    assert m.nees_count[-1] == len(ref.landmark_ids)
    want = np.einsum("li,lij,lj->", err, np.linalg.inv(cov), err)
    # the keyframes smoother's map NEES, to 2 % (measured 0.7 %: the same graph, its own LM)
    assert m.nees[-1] == pytest.approx(want, rel=2e-2)


def test_the_world_key_adds_the_row_scored_like_a_filter_and_not_ranked():
    w = small_drone_world(runs=2, filters={"names": ["ekf"], "online": True})
    assert w.filters.online
    s = run_campaign(w, runs=2, seed=0).summary
    e = s["online"][ONLINE]
    assert e["runs_scored"] == 2 and 0.2 < e["anees"] < 5.0 and 0.0 < e["pos_rmse_m"] < 1.0
    assert e["landmark_rmse_m"] > 0.0 and e["time_per_step_s"] > 0.0
    assert e["landmark_anees_dof"] == 3 and 0.0 < e["landmark_anees"] < 10.0
    assert ONLINE not in s["ranking"]["position"]["order"]
    assert "online" not in run_campaign(small_drone_world(runs=1, filters={"names": ["ekf"]}),
                                        runs=1, seed=0).summary
    with pytest.raises(WorldError, match=r"\[filters\] online = 3: must be true or false"):
        small_drone_world(filters={"names": ["ekf"], "online": 3})


def test_cli_online_on_a_drone_world(tmp_path):
    world = str(Path(__file__).parents[3] / "golden" / "small-drone.toml")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", world, "--online", "--runs", "1", "--filters",
                                    "ekf", "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert json.loads((out / "summary.json").read_text())["online"][ONLINE]["runs_scored"] == 1
    table = res.output.split("\n\n")[0]
    assert "isam2" in table and max(len(line) for line in table.splitlines()) <= 100
    res = CliRunner().invoke(main, ["run", world, "--fixed-lag", "2", "--runs", "1"])
    assert res.exit_code == 2 and "has no fixed-lag rows" in res.output
