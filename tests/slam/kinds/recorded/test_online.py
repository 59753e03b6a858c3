"""The recorded log's online row (``isam2``, ``--online``): iSAM2's current pose after each
filter epoch, from the smoother's own pass."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import gtsam
import numpy as np
import pytest
from click.testing import CliRunner

from slam.cli import main
from slam.kinds.planar.odometry import world_to_body_cov
from slam.kinds.recorded.log import format_odometry_log, parse_odometry_log
from slam.kinds.recorded.models import recorded_epochs
from slam.kinds.recorded.online import online_recorded
from slam.kinds.recorded.reference import smooth_recorded
from slam.kinds.recorded.scoring import to_online
from tests.slam.kinds.recorded.synthetic import synthetic_log


@pytest.fixture(scope="module")
def park():
    """The first 1200 records of Victoria Park (750 poses, 410 filter epochs)."""
    lines = Path(gtsam.findExampleDataFile("victoria_park.txt")).read_text().splitlines()
    log = parse_odometry_log("\n".join(lines[:1200]) + "\n", "vp-1200")
    steps = recorded_epochs(log)
    return log, steps, *online_recorded(log, steps, final_marginal=True)


def test_the_online_row_is_a_full_lm_re_solve_of_the_records_up_to_each_epoch(park):
    """At 8 epochs spread over the log, the row is the LM optimum of the records up to
    that pose (the smoother of the log's prefix) to 1 cm / 5e-4 rad, and its σ that
    optimum's marginal to 2 % (measured worst: 5.3 mm, 2.0e-4 rad, 0.84 %: iSAM2
    relinearises only past its 0.1 threshold)."""
    log, steps, row, _ = park
    worst = np.zeros(3)
    for e in np.linspace(1, len(steps) - 1, 8).astype(int):
        sub = smooth_recorded(log.prefix(int(steps[e]) + 1), final_marginal=True)
        d = sub.poses[-1] - row.poses[e]
        sigma_lm = np.sqrt(np.diag(sub.final_pose_cov))
        sigma_on = np.sqrt(np.diag(world_to_body_cov(row.poses[e, 2], row.pose_cov[e])))
        worst = np.maximum(worst, [np.hypot(d[0], d[1]), abs(d[2]),
                                   np.max(np.abs(sigma_on / sigma_lm - 1.0))])
    assert worst[0] < 1e-2 and worst[1] < 5e-4 and worst[2] < 2e-2, worst
    np.testing.assert_array_equal(row.steps, steps)
    assert np.all(np.isfinite(row.poses)) and np.all(np.linalg.eigvalsh(row.pose_cov[1:]) > 0)


def test_the_smoother_from_the_online_pass_is_the_plain_one(park):
    log, _, row, ref = park
    plain = smooth_recorded(log, final_marginal=True)
    assert ref.objective == plain.objective
    np.testing.assert_array_equal(ref.poses, plain.poses)
    np.testing.assert_array_equal(ref.final_pose_cov, plain.final_pose_cov)
    np.testing.assert_array_equal(row.landmark_ids, plain.landmark_ids)
    assert 0.0 < ref.time_isam2_s < row.time_s  # the row pays the reads, the smoother not
    # the last epoch is the last pose: iSAM2's marginal there is the smoother's, to the
    # difference of their linearisation points
    final = np.sqrt(world_to_body_cov(row.poses[-1, 2], row.pose_cov[-1])[2, 2])
    assert final == pytest.approx(np.sqrt(plain.final_pose_cov[2, 2]), rel=1e-3)


def test_the_difference_to_the_online_row_is_over_the_common_epochs(park):
    _, _, row, _ = park
    poses = row.poses.copy()
    poses[:, 0] += 0.3
    poses[5:, 2] += np.radians(2.0)
    poses[-3:] = np.nan  # a filter that diverged near the end
    d = to_online(replace(row, poses=poses), row)
    assert d["pose_rmse_to_online_m"] == pytest.approx(0.3, rel=1e-9)
    n = len(poses) - 3
    assert d["heading_rmse_to_online_deg"] == pytest.approx(2.0 * np.sqrt((n - 5) / n), rel=1e-9)
    assert to_online(replace(row, steps=row.steps[:-1], poses=poses[:-1]), row) == {}


def test_cli_online_adds_the_row_and_every_final_heading_sigma(tmp_path):
    log = synthetic_log(np.random.default_rng(2), n_poses=30, n_landmarks=4)
    path = tmp_path / "small.txt"
    path.write_text(format_odometry_log(log))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--log", str(path), "--out", str(out),
                                    "--filters", "ekf,ekf-inv", "--online", "--no-plots"])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "summary.json").read_text())
    row = data["online"]["isam2"]
    assert row["diverged"] is False and np.isfinite(row["pose_rmse_to_ref_m"])
    for e in (*data["filters"].values(), row, data["reference"]["gtsam"]):
        assert e["final_heading_sigma_deg"] > 0.0
    for e in data["filters"].values():  # the difference to the online row, in the report
        assert e["pose_rmse_to_online_m"] >= 0.0 and e["heading_rmse_to_online_deg"] >= 0.0
    assert "pose RMSE to isam2 (m)" in (out / "report.md").read_text()
    assert sorted(data["ranking"]["position"]["order"]) == ["ekf", "ekf-inv"]  # not ranked
    assert "isam2" in res.output and "ms/epoch" in res.output
    table = res.output.split("\n\n")[1]  # under the log's sentence
    assert "isam2" in table and max(len(line) for line in table.splitlines()) <= 100
    assert (out / "isam2.tum").read_text().startswith("# small.txt: isam2; time column")
    res = CliRunner().invoke(main, ["run", "--log", str(path), "--fixed-lag", "2"])
    assert res.exit_code == 2 and "--fixed-lag" in res.output and "fixed-lag rows" in res.output
