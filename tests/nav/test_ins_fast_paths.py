"""The INS filters' faster paths against the ones they replace, on random INS states: the
GNSS update through the rows it reads (``Measurement.reads`` on the INS product space, and
the Kalman update of a model that ``selects`` them) against the dense sigma-point update; the
error transition's composition by sums against the pairwise one, its F from the cached
template against the error model (the preintegration against its per-sample sums:
``tests/nav/test_nav_library.py``)."""

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


@pytest.mark.parametrize("N", [1, 2, 7, 10])
def test_compose_sums_equals_the_pairwise_composition(N):
    from nav.ins import compose, compose_sums

    rng = np.random.default_rng(N)
    Phis = np.eye(15) + 0.1 * rng.normal(size=(N, 15, 15))
    A = rng.normal(size=(N, 15, 15))
    Qs = A @ np.swapaxes(A, -1, -2)
    Phi, Q = compose_sums(Phis, Qs)
    Phi_ref, Q_ref = compose(Phis, Qs)
    assert _rel(Phi, Phi_ref) < 1e-13 and _rel(Q, Q_ref) < 1e-13
    batched = compose_sums(np.stack([Phis, Phis[::-1]]), np.stack([Qs, Qs[::-1]]))
    assert _rel(batched[1][1], compose(Phis[::-1], Qs[::-1])[1]) < 1e-13


def test_error_matrices_from_the_cached_template_are_the_error_model():
    """F of the module docstring, entry by entry, with the Earth rate and Markov biases."""
    from nav.imu_noise import datasheet_psd
    from nav.ins import InsModel, error_matrices
    from nav.quaternion import qto_dcm, skew

    rng = np.random.default_rng(2)
    psd = datasheet_psd(0.2, 0.05, gyro_bias_instability_deg_h=10.0, gyro_bias_time_s=60.0,
                        accel_random_walk_mps2_sqrt_h=0.01)
    er = np.array([0.0, 5e-5, 4e-5])
    model = InsModel(psd, np.array([0, 0, -9.81]), er)
    C = np.stack([qto_dcm(qexp(rng.normal(size=3))) for _ in range(4)])
    w, f = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    F = error_matrices(C, w, f, model)
    for k in range(4):
        ref = np.zeros((15, 15))
        ref[0:3, 3:6] = np.eye(3)
        ref[3:6, 3:6] = -2.0 * skew(er)
        ref[3:6, 6:9] = -C[k] @ skew(f[k])
        ref[3:6, 12:15] = -C[k]
        ref[6:9, 6:9] = -skew(w[k])
        ref[6:9, 9:12] = -np.eye(3)
        ref[9:12, 9:12] = -psd.gyro_bias.rate() * np.eye(3)
        ref[12:15, 12:15] = -psd.accel_bias.rate() * np.eye(3)
        np.testing.assert_array_equal(F[k], ref)
    assert psd.gyro_bias.rate() > 0.0


def test_the_homogeneous_dcm_is_dcm_unit():
    from nav.ins import _DCM_TABLE
    from nav.strapdown import dcm_unit

    q = qexp(np.random.default_rng(4).normal(0, 2.0, (50, 3)))
    C = ((q[:, :, None] * q[:, None, :]).reshape(50, 16) @ _DCM_TABLE).reshape(50, 3, 3)
    np.testing.assert_allclose(C, dcm_unit(q), rtol=0, atol=1e-15)


def test_one_attitude_paths_of_the_quaternion_space_equal_the_broadcast_ones():
    """retract / local / mean with one reference attitude (a (m, 4) @ (4, 4) product and the
    series-free log) against qmul / qlog broadcasting; tiny, zero and near-π rotations."""
    from nav.quaternion import qconj, qlog, qmul, qnormalize
    from nav.spaces import UnitQuaternion

    rng = np.random.default_rng(6)
    uq = UnitQuaternion()
    x = qexp(rng.normal(size=3))
    d = np.concatenate([rng.normal(0, 0.05, (20, 3)), rng.normal(0, 1e-9, (5, 3)),
                        np.zeros((1, 3)), [[np.pi - 1e-6, 0.0, 0.0], [0.0, -3.0, 1.0]]])
    Y = uq.retract(x[None], d)
    ref = qnormalize(qmul(x[None], qexp(d)))
    np.testing.assert_allclose(Y, ref, rtol=0, atol=1e-15)
    for xx in (x, x[None]):
        np.testing.assert_allclose(uq.local(xx, Y), qlog(qmul(qconj(xx), Y)), rtol=1e-12,
                                   atol=1e-15)
    np.testing.assert_allclose(uq.local(x[None], Y[:26]), d[:26], rtol=1e-9, atol=1e-15)
    w = np.full(20, 1 / 20)
    q = uq.mean(Y[:20], w)
    batched = uq.mean(Y[None, :20], w)[0]  # the broadcasting iteration
    np.testing.assert_allclose(q * np.sign(q[0]), batched * np.sign(batched[0]), atol=1e-14)


def test_noise_from_pd_is_from_cov_on_a_positive_definite_covariance():
    from estimators.models import Noise, NoiseError

    A = np.random.default_rng(8).normal(size=(15, 15))
    P = A @ A.T + 1e-6 * np.eye(15)
    fast, ref = Noise.from_pd(P), Noise.from_cov(P)
    np.testing.assert_allclose(fast.sqrt, ref.sqrt, rtol=0, atol=1e-14 * np.abs(ref.sqrt).max())
    np.testing.assert_array_equal(fast.cov, fast.cov.T)
    assert Noise.from_pd(np.diag([1.0, 0.0])) is None  # singular: another constructor
    with pytest.raises(NoiseError, match="not finite"):
        Noise.from_pd(np.array([[1.0, np.nan], [np.nan, 1.0]]))
    with pytest.raises(NoiseError, match="square"):
        Noise.from_pd(np.ones((2, 3)))
