"""The planar online rows (iSAM2's current pose, fixed-lag smoothers), the chunked smoother
and the time segments."""

from __future__ import annotations

import re

import gtsam
import numpy as np
import pytest
from click.testing import CliRunner
from gtsam.symbol_shorthand import X

from slam import cli
from slam.campaign import run_campaign
from slam.kinds.planar.odometry import relative_motions, world_to_body_cov
from slam.kinds.planar.online import (
    at_filter_epochs,
    fixed_lag_planar,
    online_planar,
)
from slam.kinds.planar.reference import (
    DEFAULT_LATERAL_SIGMA_M,
    SIGMA_FLOOR,
    GraphInputs,
    graph_inputs,
    incremental,
    smooth_planar,
)
from slam.kinds.planar.segments import CLOSURE, WINDOW_END, loop_closure_step, run_events
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import epochs_of
from slam.kinds.planar.world import ONLINE
from slam.mapping.online_map import ONLINE_MAP_STRIDE
from slam.nulls import unexplained_nulls
from tests.slam.test_cli import SMALL_WORLD
from tests.small_worlds import small_world
from worlds import WorldError


@pytest.fixture(scope="module")
def two_laps():
    """Two laps of the small square (426 graph epochs, a loop closure in lap 2)."""
    return simulate_planar(small_world(runs=1, vehicle={"loops": 2}), np.random.default_rng(3))


@pytest.fixture(scope="module")
def online_run(two_laps):
    g = graph_inputs(two_laps)
    return g, *online_planar(two_laps, g.steps)


def _lm(graph, init):
    p = gtsam.LevenbergMarquardtParams()
    p.setRelativeErrorTol(1e-12)
    p.setAbsoluteErrorTol(1e-14)
    p.setMaxIterations(200)
    return gtsam.LevenbergMarquardtOptimizer(graph, init, p).optimize()


def test_the_online_row_is_a_full_lm_re_solve_of_the_graph_up_to_each_epoch(two_laps,
                                                                             online_run):
    """At 8 epochs spread over the run, iSAM2's pose after the update of epoch k is the LM
    optimum of the graph of epochs 0..k to 5 mm / 2e-4 rad and its σ its marginal's to 3 %
    (measured worst: 3.2 mm, 7.7e-5 rad, 2.0 %: iSAM2's partial relinearisation)."""
    g, track, _ = online_run
    worst = np.zeros(3)
    for e in np.linspace(1, len(g.steps) - 1, 8).astype(int):
        sub = GraphInputs(g.steps[:e + 1], g.rel[:e], g.rel_cov[:e], g.prior)
        graph, isam, _ = incremental(two_laps, sub, chunk=e + 1)
        values = _lm(graph, isam.calculateEstimate())
        k = int(g.steps[e])
        p = values.atPose2(X(k))
        d = np.array([p.x(), p.y(), p.theta()]) - track.poses[e]
        sigma_lm = np.sqrt(np.diag(gtsam.Marginals(graph, values).marginalCovariance(X(k))))
        sigma_on = np.sqrt(np.diag(world_to_body_cov(track.poses[e, 2], track.pose_cov[e])))
        worst = np.maximum(worst, [np.hypot(d[0], d[1]), abs(d[2]),
                                   np.max(np.abs(sigma_on / sigma_lm - 1.0))])
    assert worst[0] < 5e-3 and worst[1] < 2e-4 and worst[2] < 3e-2, worst


def test_the_final_smoother_from_the_online_pass_is_the_chunked_one(two_laps, online_run):
    _, _, ref_epoch = online_run
    for chunk in (64, 10_000):
        ref = smooth_planar(two_laps, chunk=chunk)
        assert ref.objective == pytest.approx(ref_epoch.objective, rel=1e-9)
        np.testing.assert_allclose(ref.poses[:, :2], ref_epoch.poses[:, :2], atol=1e-6)
    with pytest.raises(ValueError, match="chunk"):
        smooth_planar(two_laps, chunk=0)


def test_a_lag_longer_than_the_run_is_the_online_optimum(two_laps, online_run):
    g, track, _ = online_run
    """A lag longer than the run: LM over the whole graph after every epoch (a full re-solve
    at each of the 426 epochs), the iSAM2 row to 7.5 mm / 2.5e-4 rad / 3 % of σ (measured
    worst: 5.9 mm, 1.9e-4 rad, 2.0 %: iSAM2's partial relinearisation)."""
    long = fixed_lag_planar(two_laps, g.steps, 1e6)
    assert long.name == "fls-1e+06s"
    d = long.poses - track.poses
    sig = np.sqrt(np.diagonal(long.pose_cov, axis1=1, axis2=2)[1:])
    sig_on = np.sqrt(np.diagonal(track.pose_cov, axis1=1, axis2=2)[1:])
    worst = (np.max(np.hypot(d[:, 0], d[:, 1])), np.max(np.abs(d[:, 2])),
             np.max(np.abs(sig / sig_on - 1.0)))
    assert worst[0] < 7.5e-3 and worst[1] < 2.5e-4 and worst[2] < 3e-2, worst


def test_lag_zero_keeps_the_map_and_a_proper_covariance(two_laps, online_run):
    g, track, _ = online_run
    zero = fixed_lag_planar(two_laps, g.steps, 0.0)
    assert zero.name == "fls-0s"
    assert np.all(np.linalg.eigvalsh(zero.pose_cov[1:]) > 0.0)
    np.testing.assert_array_equal(zero.landmark_ids, track.landmark_ids)
    assert np.max(np.hypot(*(zero.poses - track.poses)[:, :2].T)) < 0.5  # a filter's error


def test_the_online_map_is_scored_at_every_tenth_epoch_and_the_last(two_laps):
    """The row's map series holds values at the filter epochs of graph epochs 0, 10, 20, ...
    and the last, NaN (count 0) elsewhere; at the last epoch its NEES sum is the final
    map's, from the same iSAM2 state (each landmark's marginal), to 1e-6 relative (single
    precision storage)."""
    g = graph_inputs(two_laps)
    track, _ = online_planar(two_laps, g.steps, landmark_cov=True)
    m = track.map_series
    sampled = np.r_[np.arange(0, len(g.steps), ONLINE_MAP_STRIDE), len(g.steps) - 1]
    assert np.array_equal(np.flatnonzero(np.isfinite(m.nees)), np.unique(sampled))
    assert np.all(m.nees_count[np.isnan(m.nees)] == 0)
    err = track.landmarks - two_laps.landmarks[track.landmark_ids]
    nees = np.einsum("li,lij,lj->", err, np.linalg.inv(track.landmark_cov), err)
    assert m.nees[-1] == pytest.approx(nees, rel=1e-6)
    assert m.nees_count[-1] == m.n[-1] == len(track.landmark_ids)
    assert m.sq_err[-1] == pytest.approx(np.sum(err**2), rel=1e-6)


def test_filter_epochs_between_graph_epochs_are_odometry_predictions(two_laps, online_run):
    """A filter epoch between two graph epochs (no observation there): the previous
    epoch's pose composed with the odometry, its body-frame marginal propagated through the
    composition plus the odometry's covariance (lateral σ and floor)."""
    g, track, _ = online_run
    e = 100
    mid = int(g.steps[e]) + 3
    steps = np.sort(np.r_[g.steps, mid])
    body = world_to_body_cov(track.poses[:, 2], track.pose_cov)
    poses, covs = at_filter_epochs(two_laps, g.steps, steps, track.poses, body)
    i = e + 1  # mid's index among the filter epochs
    np.testing.assert_array_equal(np.delete(poses, i, 0), track.poses)
    np.testing.assert_allclose(np.delete(covs, i, 0), track.pose_cov, rtol=1e-12, atol=1e-18)
    rel, rel_cov = relative_motions(two_laps.controls, two_laps.control_cov, two_laps.dt,
                                    two_laps.wheelbase, steps)
    delta = gtsam.Pose2(*rel[e])
    want = gtsam.Pose2(*track.poses[e]).compose(delta)
    np.testing.assert_allclose(poses[i], [want.x(), want.y(), want.theta()], atol=1e-12)
    ad = delta.inverse().AdjointMap()
    extra = np.diag([SIGMA_FLOOR**2, DEFAULT_LATERAL_SIGMA_M**2 + SIGMA_FLOOR**2,
                     SIGMA_FLOOR**2])
    np.testing.assert_allclose(world_to_body_cov(poses[i, 2], covs[i]),
                               ad @ body[e] @ ad.T + rel_cov[e] + extra, rtol=1e-9, atol=1e-18)


def test_at_filter_epochs_needs_every_graph_epoch(two_laps):
    g = graph_inputs(two_laps)
    with pytest.raises(ValueError, match="every graph epoch"):
        at_filter_epochs(two_laps, g.steps, g.steps[::2], np.zeros((len(g.steps), 3)),
                         np.zeros((len(g.steps), 3, 3)))


def test_the_loop_closure_is_the_first_re_sighting_after_30_s(two_laps):
    k = loop_closure_step(two_laps)
    last: dict[int, int] = {}
    first = None
    for step, j in zip(two_laps.obs_step, two_laps.obs_id):
        if j in last and (step - last[j]) * two_laps.dt >= 30.0 and first is None:
            first = int(step)
        last[int(j)] = int(step)
    assert k == first is not None
    steps = epochs_of(two_laps, 8)
    ev = run_events(two_laps, steps)
    assert steps[ev[CLOSURE]] == k
    end = ev[WINDOW_END]
    assert steps[end - 1] * two_laps.dt < k * two_laps.dt + 60.0
    assert end == len(steps) or steps[end] * two_laps.dt >= k * two_laps.dt + 60.0
    no_gap = simulate_planar(small_world(runs=1, sensor={"max_range_m": 100.0}),
                             np.random.default_rng(3))  # every landmark always in range
    assert loop_closure_step(no_gap) is None and run_events(no_gap, epochs_of(no_gap, 8)) == {}


def test_a_campaign_scores_the_online_rows_apart_from_the_filters():
    w = small_world(runs=2, filters=("ekf",), vehicle={"loops": 3},
                    filter_options={"online": True, "fixed_lags_s": [0, 2.5]})
    s = run_campaign(w, filters=["ekf"], runs=2, seed=0, workers=1).summary
    assert list(s["online"]) == [ONLINE, "fls-0s", "fls-2.5s"]
    assert list(s["filters"]) == ["ekf"]
    for entry in s["online"].values():
        assert entry["diverged_runs"] == 0 and entry["anees"] > 0 and entry["time_per_step_s"] > 0
        assert "nis_mean" not in entry
    seg = s["segments"]
    assert seg["runs_with_closure"] == 2
    assert set(seg["estimators"]) == {"ekf", ONLINE, "fls-0s", "fls-2.5s"}
    ratio = seg["estimators"]["ekf"]["ratio_to_isam2"]
    for part in ("before", "window", "rest"):
        want = (seg["estimators"]["ekf"][part]["anees"]
                / seg["estimators"][ONLINE][part]["anees"])
        assert ratio[part] == pytest.approx(want)
    assert 0 < s["online"][ONLINE]["landmark_anees"] and "landmark_anees" in s["filters"]["ekf"]
    assert "landmark_anees" not in s["online"]["fls-0s"]  # no map over time for fixed lags
    for metric in s["ranking"].values():
        assert metric["order"] == ["ekf"]  # the online rows are not ranked
    assert unexplained_nulls(s) == []


@pytest.mark.parametrize("options, key, why", [
    ({"online": 1}, "online", "must be true or false"),
    ({"fixed_lags_s": [-1.0]}, "fixed_lags_s", "must be in [0, 1e+06]"),
    ({"fixed_lags_s": [2, 2.0]}, "fixed_lags_s", "repeats lag 2 s"),
    ({"fixed_lags_s": "2"}, "fixed_lags_s", "must be a list"),
])
def test_bad_online_keys_are_refused(options, key, why):
    with pytest.raises(WorldError) as exc:
        small_world(filter_options=options)
    assert key in str(exc.value) and why in str(exc.value)


def test_the_cli_adds_the_online_rows(tmp_path):
    world = tmp_path / "small.toml"
    world.write_text(SMALL_WORLD)
    res = CliRunner().invoke(cli.main, ["run", str(world), "--online", "--fixed-lag", "1",
                                        "--fixed-lag", "1.0", "--runs", "1", "--workers", "1",
                                        "--no-plots", "--out", str(tmp_path / "o")],
                           catch_exceptions=False)
    assert res.exit_code == 0, res.output
    for row in ("isam2", "fls-1s"):
        assert re.search(rf"^{row}\s", res.output, re.M)
    assert cli.default_folder("small", {"runs": 1, "seed": 5, "mode": "joint",
                                        "filters": ["ekf"], "online": ["isam2", "fls-1s"]},
                              {"runs": 2, "seed": 5, "mode": "joint", "filters": ["ekf"],
                               "online": []}) == "small-runs1-isam2+fls-1s"


@pytest.mark.parametrize("args, why", [
    (["--fixed-lag", "-1"], "--fixed-lag -1: must be in [0, 1e6] seconds"),
    (["--fixed-lag", "nan"], "--fixed-lag nan: must be in [0, 1e6] seconds"),
    (["star-sensor", "--online"], "--online: world star-sensor (kind attitude) has no "
                                  "online rows"),
])
def test_bad_online_options_exit_2(tmp_path, args, why):
    world = tmp_path / "small.toml"
    world.write_text(SMALL_WORLD)
    argv = ["run"] + ([] if args[0] == "star-sensor" else [str(world)]) + args
    res = CliRunner().invoke(cli.main, argv + ["--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert why in res.output and not (tmp_path / "o").exists()
