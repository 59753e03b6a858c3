"""Recorded logs in GTSAM's planar text format: parser, models, filters vs smoother, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from estimators.ekf import numerical_jacobian
from slam.cli import main
from slam.kinds.planar.models import state_space
from slam.kinds.recorded.log import (
    LogFormatError,
    OdometryLog,
    format_odometry_log,
    parse_odometry_log,
    read_odometry_log,
)
from slam.kinds.recorded.models import (
    odometry_model,
    point_augmentation_model,
    point_observation_model,
    run_recorded,
)
from slam.kinds.recorded.reference import smooth_recorded
from slam.kinds.recorded.scoring import score_filter

FILTERS = ("ekf", "srckf", "srukf", "srcdkf")


def synthetic_log(rng: np.random.Generator, n_poses: int = 40, n_landmarks: int = 6
                  ) -> OdometryLog:
    """A random chain with id gaps, landmark ids interleaved with pose ids, sightings at
    the first pose and per-record covariances (non-diagonal ones too)."""
    ids, nxt, lm_ids = [], 3, []
    for _ in range(n_poses):
        ids.append(nxt)
        nxt += 1
        if rng.random() < 0.2 and len(lm_ids) < n_landmarks:
            lm_ids.append(nxt)
            nxt += 1
    while len(lm_ids) < n_landmarks:
        lm_ids.append(nxt)
        nxt += 1
    odo = np.column_stack([rng.uniform(0.2, 1.0, n_poses - 1), rng.normal(0, 0.01, n_poses - 1),
                           rng.normal(0, 0.05, n_poses - 1)])
    A = rng.normal(size=(n_poses - 1, 3, 3)) * [0.01, 0.003, 0.002]
    odo_cov = A @ np.swapaxes(A, 1, 2) + np.eye(3) * 1e-6
    obs_pose = np.sort(np.concatenate([[0, 0], rng.integers(0, n_poses, 30)]))
    obs_id = np.array(lm_ids)[rng.integers(0, n_landmarks, len(obs_pose))]
    obs = rng.normal(0, 8.0, (len(obs_pose), 2))
    B = rng.normal(size=(len(obs_pose), 2, 2)) * 0.3
    obs_cov = B @ np.swapaxes(B, 1, 2) + np.eye(2) * 0.05
    return OdometryLog(np.array(ids), odo, odo_cov, obs_pose, obs_id, obs, obs_cov, "syn")


def test_round_trip_of_a_synthetic_file(tmp_path):
    log = synthetic_log(np.random.default_rng(0))
    path = tmp_path / "syn.txt"
    path.write_text(format_odometry_log(log))
    back = read_odometry_log(path)
    assert back.equals(log) and back.source == str(path)
    assert format_odometry_log(back) == path.read_text()
    assert back.n_poses == 40 and len(back.landmark_ids) == 6


def test_parser_reads_gtsam_layout_comments_and_blank_lines():
    text = ("# a comment\n\nLANDMARK 0 9 1 2 0.4 0 0.4\n"
            "ODOMETRY 0 1 0.5 0 0.1 0.0001 0 0 4e-06 0 4e-06  # trailing\n"
            "LANDMARK 1 9 3 -4 0.5 0.1 0.3\nODOMETRY 1 4 1 0 0 1 0 0 1 0 1\n")
    log = parse_odometry_log(text, "t.txt")
    assert log.pose_ids.tolist() == [0, 1, 4]
    np.testing.assert_array_equal(log.odometry_cov[0], np.diag([1e-4, 4e-6, 4e-6]))
    np.testing.assert_array_equal(log.obs_cov[1], [[0.5, 0.1], [0.1, 0.3]])
    assert log.obs_pose.tolist() == [0, 1] and log.obs_id.tolist() == [9, 9]
    assert log.obs[1].tolist() == [3.0, -4.0]


GOOD = "ODOMETRY 0 1 1 0 0 1e-4 0 0 4e-6 0 4e-6\n"


@pytest.mark.parametrize("text, line, needle", [
    (GOOD + "LANDMARK 1 7 3 x 0.4 0 0.4\n", 2, "'x' is not a number"),
    (GOOD + "LANDMARK 1 7 3 4 0.4 0\n", 2, "LANDMARK needs 7 fields"),
    (GOOD + "ODOMETRY 1 2 1 0 0 1e-4 0 0 4e-6 0\n", 2, "ODOMETRY needs 11 fields"),
    (GOOD + "ODOMETRY 1 2.5 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "'2.5' is not an integer id"),
    (GOOD + "LANDMARK -1 7 3 4 0.4 0 0.4\n", 2, "pose id -1 is negative"),
    (GOOD + "VERTEX2 1 0 0 0\n", 2, "unknown record 'VERTEX2'"),
    (GOOD + "LANDMARK 1 7 3 4 0.4 0 -0.4\n", 2, "not positive definite"),
    (GOOD + "LANDMARK 1 7 3 nan 0.4 0 0.4\n", 2, "'nan' is not finite"),
    (GOOD + "ODOMETRY 0 2 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "one chain"),
    (GOOD + "ODOMETRY 1 0 1 0 0 1e-4 0 0 4e-6 0 4e-6\n", 2, "pose 0 already appeared"),
    (GOOD + "LANDMARK 1 0 3 4 0.4 0 0.4\n", 2, "id 0 is also a pose id"),
    ("\n" + GOOD + "LANDMARK 5 7 3 4 0.4 0 0.4\n", 3, "pose 5 is not on the odometry chain"),
])
def test_malformed_lines_name_file_and_line(text, line, needle):
    with pytest.raises(LogFormatError) as err:
        parse_odometry_log(text, "bad.txt")
    assert str(err.value).startswith(f"bad.txt:{line}: ") and needle in str(err.value)
    assert err.value.line == line


def test_empty_or_missing_file_is_an_error(tmp_path):
    with pytest.raises(LogFormatError, match="no ODOMETRY or LANDMARK"):
        parse_odometry_log("# nothing\n", "e.txt")
    with pytest.raises(LogFormatError, match="file not found"):
        read_odometry_log(tmp_path / "missing.txt")


def test_cli_bad_log_exits_2_with_file_line_and_writes_nothing(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text(GOOD + "LANDMARK 1 7 3 x 0.4 0 0.4\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(bad), "--out", str(out)])
    assert res.exit_code == 2
    assert f"{bad}:2:" in res.output and "not a number" in res.output
    assert not out.exists()
    res = CliRunner().invoke(main, ["run", "--log", str(bad), "--runs", "3"])
    assert res.exit_code == 2 and "--runs does not apply to --log" in res.output


# --------------------------------------------------------------------------- models

def test_analytic_jacobians_match_numerical():
    rng = np.random.default_rng(1)
    x = np.concatenate([[1.0, -2.0, 0.7], rng.normal(0, 5, 6)])
    space = state_space(3)
    u = np.array([[0.5, 0.02, 0.1], [0.7, -0.01, -0.2]])
    tr = odometry_model(np.tile(np.diag([0.01, 0.002, 0.002]), (2, 1, 1)))
    F, G = tr.jacobian(x, u)
    J, _ = numerical_jacobian(lambda X, W: tr.f(X, u, W), x, space, space, 6, 1e-7)
    np.testing.assert_allclose(np.hstack([F, G]), J, atol=1e-7)
    me = point_observation_model(np.array([2, 0]), np.tile(np.eye(2) * 0.4, (2, 1, 1)))
    H, _ = numerical_jacobian(lambda X, W: me.h(X), x, space, me.space, 0, 1e-7)
    np.testing.assert_allclose(me.jacobian(x), H, atol=1e-7)
    z = np.array([3.0, -1.0, 5.0, 2.0])
    aug = point_augmentation_model(3, z, np.tile(np.eye(2) * 0.4, (2, 1, 1)))
    F, G = aug.jacobian(x, z)
    J, _ = numerical_jacobian(lambda X, W: aug.f(X, z, W), x, space, aug.space, 4, 1e-7)
    np.testing.assert_allclose(np.hstack([F, G]), J, atol=1e-7)
    # the measurement inverts the augmentation
    y = aug.f(x[None, :], z, np.zeros((1, 4)))[0]
    me2 = point_observation_model(np.array([3, 4]), np.tile(np.eye(2), (2, 1, 1)))
    np.testing.assert_allclose(me2.h(y[None, :])[0], z, atol=1e-12)


def _simulated_truth_log(rng: np.random.Generator) -> tuple[OdometryLog, np.ndarray, np.ndarray]:
    """A circuit among 8 landmarks with odometry and sightings drawn from the models."""
    from slam.kinds.recorded.models import pose2_compose, pose2_exp

    K = 300
    lms = np.array([[np.cos(a) * 25, np.sin(a) * 25 + 20] for a in np.linspace(0, 6, 8)])
    true_d = np.tile([0.5, 0.0, 2 * math.pi / K], (K, 1))
    cov = np.diag([0.01, 0.002, 0.002]) ** 2
    L = np.linalg.cholesky(cov)
    poses = np.zeros((K + 1, 3))
    meas = np.empty((K, 3))
    for k in range(K):
        poses[k + 1] = pose2_compose(poses[k], true_d[k])
        w = rng.normal(size=3) @ L.T
        # T_{k+1} = T_k Δ Exp(w): the recorded Δ = true Δ Exp(-w)
        meas[k] = pose2_compose(true_d[k], pose2_exp(-w[None, :])[0])
    obs_pose, obs_id, obs = [], [], []
    for k in range(1, K + 1, 3):
        c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
        for j, m in enumerate(lms):
            d = m - poses[k, :2]
            z = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
            if np.hypot(*z) < 20 and z[0] > 0:
                obs_pose.append(k)
                obs_id.append(1000 + j)
                obs.append(z + rng.normal(0, 0.2, 2))
    M = len(obs_pose)
    log = OdometryLog(np.arange(K + 1), meas, np.tile(cov, (K, 1, 1)), np.array(obs_pose),
                      np.array(obs_id), np.array(obs), np.tile(np.eye(2) * 0.04, (M, 1, 1)))
    return log, poses, lms


def test_filters_track_a_simulated_recorded_log_consistently():
    log, poses, lms = _simulated_truth_log(np.random.default_rng(4))
    dr_end = 0.0
    for name in FILTERS:
        r = run_recorded(log, name, mode="local")
        assert not r.diverged, r.failure
        e = r.poses - poses[r.steps]
        e[:, 2] = (e[:, 2] + np.pi) % (2 * np.pi) - np.pi
        nees = np.einsum("ki,ki->k", e[1:], np.linalg.solve(r.pose_cov[1:], e[1:, :, None])[..., 0])
        assert 0.2 < nees.mean() / 3 < 3.0, (name, nees.mean() / 3)
        lm_err = np.linalg.norm(r.landmarks - lms[r.landmark_ids - 1000], axis=1)
        assert lm_err.max() < 1.0
    from slam.kinds.recorded.models import dead_reckoning_poses

    dr_end = np.hypot(*(dead_reckoning_poses(log)[-1, :2] - poses[-1, :2]))
    assert np.hypot(*(r.poses[-1, :2] - poses[-1, :2])) < dr_end


# --------------------------------------------------------------------------- the real log

@pytest.fixture(scope="module")
def victoria_prefix():
    import gtsam

    path = gtsam.findExampleDataFile("victoria_park.txt")
    full = read_odometry_log(path)
    assert full.n_poses == 6969 and len(full.landmark_ids) == 151 and len(full.obs) == 3640
    return full.prefix(300)


def test_victoria_park_prefix_filters_agree_with_smoother(victoria_prefix):
    """The first 300 poses (before the first large-innovation sightings of the real log):
    every filter in local mode ends within centimetres of the smoother."""
    log = victoria_prefix
    ref = smooth_recorded(log)
    assert ref.objective <= ref.objective_isam2 + 1e-6
    assert set(ref.landmark_ids) == set(log.landmark_ids)
    for name in FILTERS:
        r = run_recorded(log, name, mode="local")
        s = score_filter(r, ref)
        assert not s["diverged"], s
        assert s["landmarks_mapped"] == len(ref.landmark_ids)
        assert s["landmark_dist_to_ref_median_m"] < 0.05, s
        assert s["landmark_dist_to_ref_max_m"] < 0.2, s
        assert s["final_pose_dist_to_ref_m"] < 0.2, s
    joint = run_recorded(log, "ekf", mode="joint")
    local = run_recorded(log, "ekf", mode="local")
    np.testing.assert_allclose(local.landmarks, joint.landmarks, atol=1e-8)


def test_cli_runs_a_log_and_writes_strict_summary(tmp_path):
    log = synthetic_log(np.random.default_rng(2), n_poses=30, n_landmarks=4)
    path = tmp_path / "small.txt"
    path.write_text(format_odometry_log(log))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(path), "--out", str(out),
                                    "--filters", "ekf,srckf"])
    assert res.exit_code == 0, res.output
    text = (out / "summary.json").read_text()
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict {c}"))
    assert data["mode"] == "local" and set(data["filters"]) == {"ekf", "srckf"}
    assert data["poses"] == 30 and "objective" in data["reference"]["gtsam"]
    assert "landmark_dist_to_ref_max_m" in data["filters"]["srckf"]
    assert "srckf" in res.output and "gtsam" in res.output
    assert sorted(p.name for p in out.iterdir()) == ["report.html", "report.md", "summary.json"]
    assert Path(path).exists()
