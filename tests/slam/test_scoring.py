"""Scores shared by the kinds (:mod:`slam.scoring`): NEES against a hand computation, NaN
where a covariance is missing or singular, the χ² band against scipy, the per-epoch
run-averaged NEES and the fraction of epochs inside the band, NIS and timing."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.stats import chi2

from slam.scoring import (
    COND_LIMIT,
    anees_band,
    anees_stats,
    nees_series,
    nis_and_timing,
    per_epoch_anees,
    track_frame,
)

# --------------------------------------------------------------------------- NEES


def test_nees_equals_a_hand_computation():
    err = np.array([[1.0, 2.0, 0.5], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
    cov = np.array([np.diag([4.0, 1.0, 0.25]),
                    [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]],
                    np.eye(3)])
    # 1/4 + 4/1 + 0.25/0.25; [1 1 1] P^-1 [1 1 1] with P^-1 = [[2,-1,0],[-1,2,0],[0,0,3]]/3
    np.testing.assert_allclose(nees_series(err, cov), [5.25, 5.0 / 3.0, 0.0], rtol=1e-14)


def test_nees_is_nan_where_the_covariance_is_absent_singular_or_the_error_unknown():
    e = np.array([0.3, -0.2, 0.05])
    good = np.diag([0.5, 0.4, 0.01])
    near = np.diag([1.0, 1.0, 1.0 / (10 * COND_LIMIT)])  # condition 10x the limit
    fine = np.diag([1.0, 1.0, 10.0 / COND_LIMIT])  # condition a tenth of it
    rank2 = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    inf = good.copy()
    inf[0, 0] = np.inf
    cov = np.array([good, np.full((3, 3), np.nan), np.zeros((3, 3)), rank2, near, fine, inf,
                    good])
    err = np.tile(e, (8, 1))
    err[7, 1] = np.nan
    out = nees_series(err, cov)
    assert out.shape == (8,)
    assert out[0] == pytest.approx(0.09 / 0.5 + 0.04 / 0.4 + 0.0025 / 0.01, rel=1e-14)
    assert np.isnan(out[[1, 2, 3, 4, 6, 7]]).all()
    assert out[5] == pytest.approx(0.09 + 0.04 + 0.0025 * COND_LIMIT / 10.0, rel=1e-9)
    # nothing usable at all: all NaN, no warning or error
    assert np.isnan(nees_series(err[:2], np.full((2, 3, 3), np.nan))).all()


# --------------------------------------------------------------------------- the band


@pytest.mark.parametrize(("runs", "dof", "level"), [(1, 3, 0.95), (2, 3, 0.95), (50, 3, 0.95),
                                                    (20, 2, 0.99), (200, 6, 0.9)])
def test_anees_band_is_the_chi_square_band(runs, dof, level):
    lo, hi = anees_band(runs, dof, level)
    n = runs * dof
    assert lo < 1.0 < hi
    # equal tails of chi2(n) / n
    assert chi2.cdf(lo * n, n) == pytest.approx((1 - level) / 2, rel=1e-9)
    assert chi2.sf(hi * n, n) == pytest.approx((1 - level) / 2, rel=1e-9)
    # and the defaults are 3 dof, 95 %
    if dof == 3 and level == 0.95:
        assert anees_band(runs) == (lo, hi)


def test_anees_band_narrows_with_runs_and_covers_95_percent_of_simulated_averages():
    widths = [hi - lo for lo, hi in (anees_band(r) for r in (1, 5, 25, 125))]
    assert all(a > b for a, b in zip(widths, widths[1:]))
    rng = np.random.default_rng(0)
    runs, samples = 10, 40_000
    e = rng.standard_normal((samples, runs, 3))
    average = (e**2).sum(axis=2).mean(axis=1) / 3.0  # run-averaged NEES / dof, P = I
    lo, hi = anees_band(runs)
    inside = np.mean((average >= lo) & (average <= hi))
    assert abs(inside - 0.95) < 0.005  # binomial sd 0.0011
    assert abs(np.mean(average < lo) - 0.025) < 0.004


# --------------------------------------------------------------------------- ANEES of a campaign


def test_per_epoch_anees_averages_the_runs_that_have_a_nees():
    nees = np.array([[3.0, 0.3, np.nan, np.nan],
                     [6.0, 0.9, 4.5, np.nan]])
    np.testing.assert_allclose(per_epoch_anees(nees, 3), [1.5, 0.2, 1.5, np.nan])
    np.testing.assert_allclose(per_epoch_anees(nees, 2), [2.25, 0.3, 2.25, np.nan])


def test_anees_stats_value_band_and_fraction_of_epochs_inside():
    lo, hi = anees_band(2)  # [0.206, 2.408] for 2 runs x 3 dof
    # per-epoch run averages / 3: 1.0, 0.1 (below), 3.0 (above), 2.0, 1.5 (one run only),
    # and an epoch without any NEES (left out)
    nees = np.array([[3.0, 0.3, 9.0, 6.0, np.nan, np.nan],
                     [3.0, 0.3, 9.0, 6.0, 4.5, np.nan]])
    stats = anees_stats(nees, 3)
    per_epoch = np.array([1.0, 0.1, 3.0, 2.0, 1.5])
    assert stats["value"] == pytest.approx(per_epoch.mean(), rel=1e-14)
    assert stats["band"] == [lo, hi]
    assert stats["inside"] == pytest.approx(3 / 5, rel=1e-14)
    assert stats["above"] == pytest.approx(1 / 5, rel=1e-14)
    assert stats["distance"] == 0.0  # the ANEES (1.52) itself is inside the band
    # the band is for the number of runs and the dof given
    two = anees_stats(nees[:, :4] * 2.0 / 3.0, 2)
    assert two["band"] == list(anees_band(2, 2))
    assert two["value"] == pytest.approx(np.mean([1.0, 0.1, 3.0, 2.0]), rel=1e-14)


def test_anees_stats_distance_to_the_band_and_no_nees_at_all():
    lo, hi = anees_band(1)
    above = anees_stats(np.array([[3.0 * (hi + 0.5)] * 4]), 3)
    assert above["inside"] == 0.0 and above["distance"] == pytest.approx(0.5, rel=1e-12)
    below = anees_stats(np.array([[3.0 * lo / 2.0] * 4]), 3)
    assert below["distance"] == pytest.approx(lo / 2.0, rel=1e-12)
    assert anees_stats(np.full((3, 5), np.nan), 3) == {}


@dataclass(frozen=True)
class _Run:
    nis: np.ndarray
    nis_dof: np.ndarray
    steps: int
    time_s: float


def test_nis_per_dof_and_timing():
    runs = [_Run(np.array([2.0, 6.0]), np.array([2, 3]), 10, 0.5),
            _Run(np.array([1.0]), np.array([1]), 30, 1.5)]
    out = nis_and_timing(runs)
    assert out["nis_mean"] == pytest.approx((1.0 + 2.0 + 1.0) / 3, rel=1e-14)
    assert out["time_per_step_s"] == pytest.approx(2.0 / 40, rel=1e-14)
    assert out["time_per_run_s"] == pytest.approx(1.0, rel=1e-14)
    none = nis_and_timing([_Run(np.zeros(0), np.zeros(0, int), 0, 0.0)])
    assert "nis_mean" not in none and none["time_per_step_s"] == 0.0


def test_track_frame_rotates_errors_and_covariances_into_the_heading():
    # heading +90°: along-track is +y, cross-track (left) is -x
    err = np.array([[1.0, 2.0], [3.0, -1.0]])
    cov = np.array([np.diag([4.0, 9.0]), [[2.0, 1.0], [1.0, 2.0]]])
    along, sig = track_frame(err, cov, np.array([np.pi / 2, np.pi / 4]))
    np.testing.assert_allclose(along[0], [2.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(sig[0], [3.0, 2.0], atol=1e-12)
    # 45°: along = (x + y)/√2, cross = (y - x)/√2; variances 3 and 1 along the eigenvectors
    np.testing.assert_allclose(along[1], [2.0 / np.sqrt(2), -4.0 / np.sqrt(2)], atol=1e-12)
    np.testing.assert_allclose(sig[1], [np.sqrt(3.0), 1.0], atol=1e-12)
    _, nan = track_frame(err[:1], np.full((1, 2, 2), np.nan), np.zeros(1))
    assert np.isnan(nan).all()


def test_landmark_anees_entries_against_a_hand_computation():
    """Two runs of a 2-dof map: per epoch the summed NEES over (2 × the landmark blocks),
    each epoch against its own χ² band, the value their mean, the band at the median
    count; epochs without a landmark and a shorter run's missing epochs left out."""
    from slam.mapping.map_series import MapSeries
    from slam.scoring import landmark_anees_entries

    def series(nees, count):
        z = np.zeros(len(nees), dtype=np.float32)
        return MapSeries(z, z, z, np.asarray(nees, np.float32), np.asarray(count, np.float32),
                         z, 2)

    a = series([0.0, 4.0, 30.0, 6.0], [0, 2, 3, 3])
    b = series([0.0, 2.0, 1.0], [0, 1, 1])  # one epoch shorter
    out = landmark_anees_entries([a, b])
    n = np.array([3.0, 4.0, 3.0])
    value = np.array([6.0, 31.0, 6.0]) / (2 * n)
    lo, hi = chi2.ppf(0.025, 2 * n) / (2 * n), chi2.ppf(0.975, 2 * n) / (2 * n)
    inside = (value >= lo) & (value <= hi)
    assert out["landmark_anees"] == pytest.approx(value.mean(), rel=1e-6)
    assert out["landmark_anees_dof"] == 2
    assert out["landmark_anees_bounds_95"] == pytest.approx(
        [chi2.ppf(0.025, 6) / 6, chi2.ppf(0.975, 6) / 6], rel=1e-9)
    assert out["landmark_anees_steps_inside_95"] == pytest.approx(inside.mean())
    assert out["landmark_anees_steps_above_95"] == pytest.approx((value > hi).mean())
    assert not inside.all() and (value > hi).any()  # epoch 2 is above its band
    assert landmark_anees_entries([series([0.0, 0.0], [0, 0])]) == {}
    assert landmark_anees_entries([]) == {}
