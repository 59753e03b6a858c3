"""The library's consistency tools (:mod:`estimators.consistency`): NEES and NIS against hand
computations, the χ² bands against ``scipy.stats.chi2``, the NIS summary's in-band shares on
simulated χ² draws, and slam.scoring using the same functions (no second copy)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

import slam.scoring
from estimators import consistency as C


def test_nees_and_nis_of_one_vector_and_of_a_series_equal_hand_computations():
    P = np.array([[2.0, 1.0], [1.0, 2.0]])  # inverse [[2, -1], [-1, 2]] / 3
    e = np.array([1.0, -1.0])
    assert float(C.nees(e, P)) == pytest.approx((2 + 2 + 1 + 1) / 3.0, rel=1e-14)
    assert float(C.nis(np.array([3.0]), np.array([[4.0]]))) == pytest.approx(9.0 / 4.0)
    series = C.nees(np.array([e, [0.0, 2.0]]), np.array([P, np.diag([1.0, 4.0])]))
    np.testing.assert_allclose(series, [2.0, 1.0], rtol=1e-14)
    assert np.isnan(C.nees(e, np.zeros((2, 2))))  # singular: no NEES, no error


@pytest.mark.parametrize(("dof", "level"), [(1, 0.95), (3, 0.95), (7.0, 0.99), (40, 0.9)])
def test_chi2_ppf_and_band_equal_scipy(dof, level):
    lo, hi = C.chi2_band(dof, level)
    assert float(lo) == pytest.approx(chi2.ppf((1 - level) / 2, dof), rel=1e-10)
    assert float(hi) == pytest.approx(chi2.ppf((1 + level) / 2, dof), rel=1e-10)
    q = np.array([0.01, 0.5, 0.999])
    np.testing.assert_allclose(C.chi2_ppf(q, dof), chi2.ppf(q, dof), rtol=1e-10)


def test_anees_band_of_runs_is_the_band_of_their_sum():
    lo, hi = C.anees_band(12, 2, 0.95)
    assert lo == pytest.approx(chi2.ppf(0.025, 24) / 24, rel=1e-10)
    assert hi == pytest.approx(chi2.ppf(0.975, 24) / 24, rel=1e-10)


def test_anees_stats_in_band_share_by_hand():
    lo, hi = C.anees_band(1, 1)
    nees = np.array([[1.0, lo / 2, hi * 2, 0.5, np.nan]])
    st = C.anees_stats(nees, 1)
    assert st["value"] == pytest.approx(np.mean([1.0, lo / 2, hi * 2, 0.5]))
    assert st["inside"] == 0.5 and st["above"] == 0.25


def test_nis_stats_on_chi_square_draws_and_by_hand():
    rng = np.random.default_rng(3)
    d = rng.integers(1, 4, 20_000)
    v = chi2.rvs(d, random_state=rng)
    st = C.nis_stats(v, d)
    assert abs(st["inside"] - 0.95) < 0.006  # binomial sd 0.0015
    assert abs(st["above"] - 0.025) < 0.004
    assert st["band"][0] < st["per_dof"] < st["band"][1]
    # by hand: NIS 2 of 1 dof and 6 of 3 dof (a NaN left out): Σν/Σd = 8/4
    hand = C.nis_stats([2.0, 6.0, np.nan], [1, 3, 2])
    assert hand["per_dof"] == 2.0 and hand["mean"] == 2.0 and hand["updates"] == 2
    assert hand["band"] == pytest.approx([chi2.ppf(0.025, 4) / 4, chi2.ppf(0.975, 4) / 4])
    over = C.nis_stats(np.full(10, 50.0), 2)
    assert over["inside"] == 0.0 and over["above"] == 1.0
    assert C.nis_stats([np.nan], [1]) == {}


def test_slam_scoring_uses_the_library_functions():
    for name in ("nees_series", "anees_band", "anees_stats", "per_epoch_anees", "chi2_ppf"):
        assert getattr(slam.scoring, name) is getattr(C, name)


def test_two_dimensional_nees_in_closed_form_equals_a_linear_solve():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(400, 2, 2))
    P = A @ np.swapaxes(A, 1, 2) + 1e-3 * np.eye(2)
    e = rng.normal(size=(400, 2))
    ref = np.einsum("ki,ki->k", e, np.linalg.solve(P, e[..., None])[..., 0])
    P[0] = [[1.0, 1.0], [1.0, 1.0]]  # singular
    P[1] = np.diag([1.0, 1e-13])  # condition above COND_LIMIT
    P[2] = np.diag([1.0, -1.0])  # indefinite
    P[3, 0, 0] = np.nan
    e[4, 1] = np.inf
    got = C.nees_series(e, P)
    assert np.all(np.isnan(got[:5]))
    np.testing.assert_allclose(got[5:], ref[5:], rtol=1e-10)
    assert C.nees_series(np.ones((1, 2)), np.diag([1.0, 1e-11])[None])[0] == pytest.approx(1e11 + 1)
