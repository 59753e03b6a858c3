""":class:`~slam.mapping.map_series.BatchMapRecorder` against the per-run
:class:`~slam.mapping.map_series.MapRecorder`, member by member: square-root and covariance
beliefs, an unknown slot, a non-finite landmark and a near-singular landmark block."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.models import Gaussian, SqrtGaussian
from estimators.partitioned import BlockLayout
from slam.kinds.planar.models import state_space
from slam.mapping.map_series import BatchMapRecorder, MapRecorder


@pytest.mark.parametrize("form", ["sqrt", "cov"])
def test_batched_recorder_is_the_per_run_one(form):
    rng = np.random.default_rng(3)
    B, n_lm = 4, 6
    n = 3 + 2 * n_lm
    lay = BlockLayout.of(state_space)
    truth = rng.normal(size=(8, 2)) * 10.0
    ids = [3, 0, -1, 7, 5, 2]  # slot 2 unknown
    S = np.tril(rng.normal(size=(B, n, n))) * 0.2
    i = np.arange(n)
    S[:, i, i] = np.abs(S[:, i, i]) + 0.1
    S[1, 3 + 2 * 4:5 + 2 * 4] = 0.0  # member 1, slot 4: a singular block (NaN, left out)
    S[1, 3 + 2 * 4, 0] = 1e-3
    mean = rng.normal(size=(B, n)) * 10.0
    mean[2, 3 + 2 * 3] = np.inf  # member 2, slot 3: a non-finite landmark
    space = state_space(n_lm)
    if form == "sqrt":
        b = SqrtGaussian(mean, S, space)
    else:
        b = Gaussian(mean, S @ np.swapaxes(S, 1, 2), space)
    batch = BatchMapRecorder(lay, B, 2, truth)
    batch.record(1, b, np.arange(B), ids)
    for j in range(B):
        one = MapRecorder(lay, 2, truth)
        one.record(1, SqrtGaussian(mean[j], S[j], space) if form == "sqrt"
                   else Gaussian(mean[j], b.cov[j], space), ids)
        got, ref = batch.values[j, :, 1], one.values[:, 1]
        assert np.array_equal(np.isnan(got), np.isnan(ref))
        ok = ~np.isnan(ref)
        np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-12)
    assert batch.values[1, 4, 1] == 4.0  # the singular block left out of the NEES count
    assert batch.values[2, 4, 1] == 4.0  # the non-finite landmark too
