"""Scores of a planar SLAM run (:mod:`slam.kinds.planar.scoring`): wrapped pose errors, the
per-run reduction, and the Monte Carlo summary of one estimator (ANEES, the fraction of
epochs inside the band, diverged runs left out)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.kinds.planar.scoring import pose_errors, reduce_run, summarize
from slam.results import RunScores
from slam.scoring import anees_band


def test_pose_errors_wrap_the_heading():
    poses = np.array([[1.0, 2.0, 3.1], [0.0, 0.0, -3.1], [5.0, 5.0, 0.2]])
    truth = np.array([[0.5, 2.5, -3.1], [0.0, 1.0, 3.1], [5.0, 5.0, 0.1]])
    err = pose_errors(poses, truth)
    np.testing.assert_allclose(err[:, :2], [[0.5, -0.5], [0.0, -1.0], [0.0, 0.0]])
    np.testing.assert_allclose(err[:, 2], [6.2 - 2 * math.pi, 2 * math.pi - 6.2, 0.1],
                               atol=1e-12)


def test_reduce_run_scores_one_estimator():
    truth = np.zeros((3, 3))
    poses = np.array([[0.0, 0.0, 0.0], [0.1, -0.2, 0.0], [0.3, 0.4, 0.01]])
    cov = np.array([np.full((3, 3), np.nan), np.diag([0.01, 0.04, 1e-4]),
                    np.diag([0.09, 0.16, 1e-4])])
    lms = np.array([[10.0, 0.0], [0.0, 10.0], [5.0, 5.0]])
    s = reduce_run("ekf", poses, cov, truth, np.array([2, -1, 0]),
                   np.array([[5.0, 5.3], [9.0, 9.0], [10.4, 0.0]]), lms,
                   np.array([1.0, 3.0]), np.array([2, 4]), 0.5)
    assert s.name == "ekf" and s.steps == 2 and not s.diverged and s.failure is None
    np.testing.assert_allclose(s.sigma[1:], [[0.1, 0.2, 0.01], [0.3, 0.4, 0.01]])
    assert np.isnan(s.sigma[0]).all() and np.isnan(s.nees[0])
    np.testing.assert_allclose(s.nees[1:], [1.0 + 1.0, 1.0 + 1.0 + 1.0])
    np.testing.assert_allclose(s.lm_err, [0.3, 0.4])  # the unknown id (-1) is left out
    assert s.nis_dof.dtype.kind == "i" and s.time_s == 0.5


# --------------------------------------------------------------------------- the summary


def scores(nees: list[float], *, diverged: bool = False, err: float = 0.1,
           name: str = "f") -> RunScores:
    n = len(nees)
    return RunScores(name, np.tile([err, -err, 0.01], (n, 1)), np.full((n, 3), 0.1),
                     np.array(nees, float), np.array([0.2, 0.4]), nis=np.array([2.0, 4.0]),
                     nis_dof=np.array([2, 2]), time_s=0.25, steps=n - 1, diverged=diverged,
                     failure="blew up" if diverged else None)


def test_summary_anees_and_the_fraction_of_epochs_inside_the_band():
    lo, hi = anees_band(2)  # [0.206, 2.408] for 2 runs x 3 dof
    # per-epoch run averages / 3: 1.0, 0.1 (below), 3.0 (above), 2.0, and an epoch where
    # one run has no NEES (the other's value alone: 1.5) and one where none has any
    a = [3.0, 0.3, 9.0, 6.0, np.nan, np.nan]
    b = [3.0, 0.3, 9.0, 6.0, 4.5, np.nan]
    out = summarize([scores(a), scores(b)])
    per_epoch = np.array([1.0, 0.1, 3.0, 2.0, 1.5])
    assert out["anees"] == pytest.approx(per_epoch.mean(), rel=1e-14)
    assert out["anees_bounds_95"] == [lo, hi]
    assert out["anees_steps_inside_95"] == pytest.approx(3 / 5, rel=1e-14)
    assert out["runs_scored"] == 2 and out["diverged_runs"] == 0
    # the other entries
    assert out["pos_rmse_m"] == pytest.approx(math.sqrt(0.02), rel=1e-12)
    assert out["pos_err_range_m"] == {"x": [0.1, 0.1], "y": [-0.1, -0.1]}
    assert out["heading_rmse_deg"] == pytest.approx(math.degrees(0.01), rel=1e-12)
    assert out["landmark_rmse_m"] == pytest.approx(math.sqrt(0.1), rel=1e-12)
    assert out["nis_mean"] == pytest.approx(1.5, rel=1e-14)
    assert out["time_per_run_s"] == 0.25
    assert out["time_per_step_s"] == pytest.approx(0.5 / 10, rel=1e-14)
    assert "heading_rmse_deg" not in summarize([scores(a)], with_heading=False)


def test_summary_leaves_diverged_runs_out():
    good, bad = scores([3.0, 3.0]), scores([300.0, 300.0], diverged=True, err=50.0)
    out = summarize([good, bad])
    assert out["runs_scored"] == 1 and out["diverged_runs"] == 1
    assert out["anees"] == pytest.approx(1.0) and out["anees_bounds_95"] == list(anees_band(1))
    assert out["pos_rmse_m"] == pytest.approx(math.sqrt(0.02))
    only_bad = summarize([bad])
    assert only_bad == {"runs_scored": 0, "diverged_runs": 1, "failures": ["blew up"]}


def test_summary_without_any_nees_has_no_anees():
    out = summarize([scores([np.nan, np.nan]), scores([np.nan, np.nan])])
    assert not {"anees", "anees_bounds_95", "anees_steps_inside_95"} & set(out)
    assert out["runs_scored"] == 2 and "pos_rmse_m" in out
