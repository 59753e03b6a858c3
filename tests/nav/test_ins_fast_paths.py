"""The INS filters' faster paths against the ones they replace, on random INS states: the
GNSS update through the rows it reads (``Measurement.reads`` on the INS product space, and
the Kalman update of a model that ``selects`` them) against the dense sigma-point update."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.models import Measurement, SqrtGaussian
from estimators.rules import CentralDifference, Cubature, Unscented
from estimators.sigma import sigma_update
from estimators.structured import dense_steps, flat_rows
from nav.gnss import gnss_measurement
from nav.ins import LAYOUT, SPACE
from nav.quaternion import qexp

RULES = [Cubature(), Unscented(1.0, 0.0, 1.0), CentralDifference()]


def _belief(rng: np.random.Generator) -> SqrtGaussian:
    x = np.concatenate([rng.normal(0, 10, 3), rng.normal(0, 5, 3), qexp(rng.normal(0, 1, 3)),
                        rng.normal(0, 1e-3, 3), rng.normal(0, 0.05, 3)])
    S = np.tril(rng.normal(size=(15, 15))) * 0.2
    S[np.arange(15), np.arange(15)] = np.abs(np.diag(S)) + 0.05
    return SqrtGaussian(x, S, SPACE)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_the_ins_space_has_six_flat_leading_rows():
    assert flat_rows(SPACE) == 6


@pytest.mark.parametrize("rule", RULES, ids=lambda r: r.name)
@pytest.mark.parametrize("kw,reads", [
    ({"position_sigma": 0.7}, (0, 1, 2)),
    ({"position_sigma": [0.5, 0.6, 1.2], "velocity_sigma": 0.1}, (0, 1, 2, 3, 4, 5)),
    ({"velocity_sigma": 0.2}, (3, 4, 5))])
def test_gnss_update_by_the_rows_read_equals_the_dense_update(rule, kw, reads):
    rng = np.random.default_rng(3)
    b = _belief(rng)
    meas = gnss_measurement(LAYOUT, **kw)
    assert meas.reads == reads
    z = meas.h(b.mean[None])[0] + rng.normal(0, 1.0, meas.noise.dim)
    assert meas.selects
    points = Measurement(meas.h, meas.noise, reads=meas.reads)  # the points along the rows
    with dense_steps():
        ref, ref_inn = sigma_update(rule, "sqrt", b, meas, z)
    for model in (meas, points):
        out, inn = sigma_update(rule, "sqrt", b, model, z)
        assert _rel(out.mean, ref.mean) < 1e-12
        assert _rel(out.cov, ref.cov) < 1e-12
        assert _rel(np.asarray(inn.nis), np.asarray(ref_inn.nis)) < 1e-12
        assert not np.array_equal(out.cov, ref.cov)  # the structured step did run


def test_selects_needs_one_row_read_per_coordinate():
    meas = gnss_measurement(LAYOUT, position_sigma=1.0)
    with pytest.raises(ValueError, match="selects"):
        Measurement(meas.h, meas.noise, selects=True)
    with pytest.raises(ValueError, match="selects"):
        Measurement(meas.h, meas.noise, reads=(0, 1), selects=True)


def test_a_lever_arm_declares_no_rows():
    assert gnss_measurement(LAYOUT, position_sigma=1.0, lever_arm=[0.1, 0, 0]).reads is None
